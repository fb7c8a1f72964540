"""Property-based fuzzing of ``POST /predict`` in-process (TestClient, tiny real checkpoint): every
request gets either a correct 200 (valid input) or a 4xx whose JSON ``detail`` says what is wrong;
never a 5xx, never a hang.

Three families: the CSV cases of the reader fuzz sent through both CSV doors (multipart upload and
``text/csv`` body), JSON-array bodies broken in JSON-specific ways, and arbitrary bytes under
arbitrary content types and query parameters.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from hypothesis import given, note, settings
from hypothesis import strategies as st

from app.schemas import PredictionResponse

PROFILE = settings.get_profile("ftin-fuzz")
# A request that runs the model costs ~10-100x a plain read: fewer examples per kind.
API_EXAMPLES = max(4, PROFILE.max_examples // 4)
HARD_LIMIT_S = 60.0  # generous for a loaded 2-core machine; a hang is far beyond it


def _check_4xx(response, mentions: tuple[str, ...] = (), fuzz_kit=None) -> str:
    assert 400 <= response.status_code < 500, (response.status_code, response.text[:500])
    body = response.json()
    assert set(body) == {"detail"} and isinstance(body["detail"], str), body
    detail = body["detail"]
    assert detail.strip() and len(detail) < 1000 and "Traceback" not in detail, detail
    if fuzz_kit is not None:
        fuzz_kit.check_mentions(detail, mentions)
    return detail


def _check_200(response, n_input: int | None, has_gt: bool | None) -> PredictionResponse:
    """A correct prediction; ``n_input`` / ``has_gt`` None: unknown (a broken file that still reads)."""
    assert response.status_code == 200, (response.status_code, response.text[:500])
    result = PredictionResponse.model_validate(response.json())
    traj = result.trajectory
    assert len(traj.t) == len(traj.x) == len(traj.y) == len(traj.z) > 1
    assert all(math.isfinite(v) for v in (*traj.t, *traj.x, *traj.y, *traj.z))
    assert all(math.isfinite(v) for v in (*result.velocity.vx, *result.velocity.vy))
    if has_gt is not None:
        assert (result.ground_truth is not None) == has_gt
    if result.ground_truth is not None and n_input is not None:
        assert len(result.ground_truth.t) == n_input
    return result


@pytest.fixture(scope="module")
def tiny_model(api) -> dict:
    (model,) = api.get("/models").json()
    return model


def _window_fit(t_s: np.ndarray, model: dict) -> str:
    """'fits', 'short' or 'borderline': does the recording, resampled to the model's rate, hold one
    full window and its end? Within two samples of the limit, resampling decides either way."""
    samples = float(t_s[-1] - t_s[0]) * model["imu_rate_hz"]
    needed = model["window"] + 1
    return "fits" if samples > needed + 2 else "short" if samples < needed - 2 else "borderline"


def _check_200_or_too_short(response, t_s: np.ndarray, model: dict, has_gt: bool | None, fuzz_kit) -> None:
    fit = _window_fit(t_s, model)
    if fit == "short" or (fit == "borderline" and response.status_code != 200):
        _check_4xx(response, ("too short",), fuzz_kit)  # the reader takes it; the model cannot
    else:
        _check_200(response, None if has_gt is None else len(t_s), has_gt)


def _post_csv(api, data: bytes, door: str, model: str | None = None):
    params = {"model": model} if model else None
    if door == "multipart":
        return api.post("/predict", files={"file": ("fuzz.csv", data, "text/csv")}, params=params)
    return api.post("/predict", content=data, headers={"content-type": "text/csv"}, params=params)


@settings(PROFILE, max_examples=API_EXAMPLES)
@given(data=st.data())
def test_predict_csv_answers_200_or_a_clear_4xx(
    mutation, data, api, tiny_model, fuzz_kit, case_counter, hard_timeout
):
    case = data.draw(fuzz_kit.cases(mutation), label="case")
    door = data.draw(st.sampled_from(("multipart", "text/csv")), label="door")
    with hard_timeout(HARD_LIMIT_S, f"POST /predict ({door}) with a {mutation} case"):
        response = _post_csv(api, case.data, door)
    case_counter.add("POST /predict csv", str(response.status_code))
    Expect = fuzz_kit.Expect
    if case.expect is Expect.VALID or (case.expect is Expect.EITHER and response.status_code == 200):
        has_gt = (case.recording.gt_p_world_m is not None) if case.expect is Expect.VALID else None
        _check_200_or_too_short(response, case.recording.t_s, tiny_model, has_gt, fuzz_kit)
    else:
        _check_4xx(response, case.mentions if case.expect is Expect.INVALID else (), fuzz_kit)


# ---------------------------------------------------------------------------------------------
# JSON arrays

_JSON_MUTATIONS = (
    "none", "nan", "infinity", "huge", "huge_int", "string_number", "null_value", "ragged_row",
    "wrong_width", "length_mismatch", "decreasing_t", "one_sample", "empty_arrays", "missing_field",
    "extra_field", "wrong_type", "bad_quaternion", "not_json", "truncated_json", "not_an_object",
    "deeply_nested", "long_name",
)  # fmt: skip


@st.composite
def json_cases(draw: st.DrawFn) -> tuple[bytes, str, bool | None, np.ndarray]:
    """(body, mutation, valid: True / False / None for either, the valid recording's t_s)."""
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    n = draw(st.integers(100, 250))
    rate_hz = draw(st.sampled_from((50.0, 100.0, 200.0)))
    t_s = np.arange(n) / rate_hz + draw(st.sampled_from((0.0, 1.7e9)))
    body: dict = {
        "name": draw(st.sampled_from(("walk", "ünïcode 🚶", "../../etc/passwd", "<script>"))),
        "t_s": t_s.tolist(),
        "gyro_rad_s": rng.normal(0, 0.5, (n, 3)).tolist(),
        "acc_m_s2": (rng.normal(0, 0.5, (n, 3)) + [0, 0, 9.81]).tolist(),
    }
    if draw(st.booleans()):
        body["gt_p_world_m"] = np.cumsum(rng.normal(0, 0.01, (n, 3)), axis=0).tolist()
    mutation = draw(st.sampled_from(_JSON_MUTATIONS))
    valid: bool | None = False
    row = draw(st.integers(0, n - 1))
    field = draw(st.sampled_from(("gyro_rad_s", "acc_m_s2")))
    raw_number: str | None = None  # a literal spliced into the JSON text where json.dumps cannot
    if mutation == "none":
        valid = True
    elif mutation in ("nan", "infinity", "huge_int"):
        raw_number = {"nan": "NaN", "infinity": "-Infinity", "huge_int": "1" + "0" * 400}[mutation]
    elif mutation == "huge":
        body[field][row][draw(st.integers(0, 2))] = draw(st.sampled_from((1e308, -1e308, 1e200, 1e6)))
    elif mutation == "string_number":
        body[field][row][0] = draw(st.sampled_from(("1.5", "abc", "")))
        valid = None  # pydantic may coerce "1.5" in lax mode
    elif mutation == "null_value":
        body[field][row][1] = None
    elif mutation == "ragged_row":
        body[field][row] = body[field][row][: draw(st.integers(0, 2))]
    elif mutation == "wrong_width":
        body[field][row] = [*body[field][row], 0.0]
    elif mutation == "length_mismatch":
        body[field] = body[field][: draw(st.integers(0, n - 1))]
    elif mutation == "decreasing_t":
        body["t_s"][row], body["t_s"][(row + 1) % n] = body["t_s"][(row + 1) % n], body["t_s"][row]
    elif mutation == "one_sample":
        body = {k: (v[:1] if isinstance(v, list) else v) for k, v in body.items()}
    elif mutation == "empty_arrays":
        body = {k: ([] if isinstance(v, list) else v) for k, v in body.items()}
    elif mutation == "missing_field":
        del body[draw(st.sampled_from(("t_s", "gyro_rad_s", "acc_m_s2")))]
    elif mutation == "extra_field":
        body["magnetometer"] = [[0.0, 0.0, 0.0]] * n
    elif mutation == "wrong_type":
        key = draw(st.sampled_from(("t_s", "gyro_rad_s", "name")))
        body[key] = draw(st.sampled_from((None, 3, "text", {"a": 1}, [["x"]])))
        valid = key == "name" and body[key] == "text"  # any other value is the wrong type
    elif mutation == "bad_quaternion":
        body["q_world_device_wxyz"] = [[1.0, 0.0, 0.0, 0.0]] * n
        body["q_world_device_wxyz"][row] = draw(st.sampled_from(([0.0] * 4, [2.0, 0, 0, 0], [1.0, 0, 0])))
    text = json.dumps(body)
    if raw_number is not None:
        key = f'"{field}": '
        at = text.index(key) + len(key) + 2  # past '[[': the first component of the first row
        end = text.index(",", at)
        text = text[:at] + raw_number + text[end:]
    data = text.encode()
    if mutation == "not_json":
        data = draw(st.sampled_from((b"", b"{", b"t_s=1", b"\xff\xfe{}", b"nul\x00l")))
    elif mutation == "truncated_json":
        data = data[: draw(st.integers(0, len(data) - 1))]
    elif mutation == "not_an_object":
        data = draw(st.sampled_from((b"[]", b"1", b'"text"', b"null", b"true")))
    elif mutation == "deeply_nested":
        depth = draw(st.integers(100, 5000))
        data = b'{"t_s": ' + b"[" * depth + b"]" * depth + b"}"
    elif mutation == "long_name":
        body["name"] = "n" * 201
        data = json.dumps(body).encode()
    return data, mutation, valid, t_s


@settings(PROFILE, max_examples=API_EXAMPLES * 6)
@given(case=json_cases())
def test_predict_json_answers_200_or_a_clear_4xx(case, api, tiny_model, fuzz_kit, case_counter, hard_timeout):
    data, mutation, valid, t_s = case
    note(f"mutation={mutation} valid={valid} body={data[:300]!r}")
    with hard_timeout(HARD_LIMIT_S, f"POST /predict (json) with a {mutation} body"):
        response = api.post("/predict", content=data, headers={"content-type": "application/json"})
    case_counter.add("POST /predict json", str(response.status_code))
    if valid is True or (valid is None and response.status_code == 200):
        _check_200_or_too_short(response, t_s, tiny_model, b'"gt_p_world_m"' in data, fuzz_kit)
    else:
        _check_4xx(response)


# ---------------------------------------------------------------------------------------------
# Arbitrary requests

_CONTENT_TYPES = (
    "", "text/csv", "text/plain", "application/json", "multipart/form-data",
    "multipart/form-data; boundary=xyz", "multipart/form-data; boundary=",
    "application/x-www-form-urlencoded", "application/octet-stream", "text/csv; charset=utf-16",
    "application/json; charset=latin-1", "image/png", "multipart/mixed; boundary=a", "TEXT/CSV",
    "text/csv;;;", "\u00e9/\u00e9",
)  # fmt: skip


@st.composite
def multipart_bodies(draw: st.DrawFn) -> tuple[bytes, str]:
    """Hand-built multipart bodies: wrong field names, two files, no filename, broken framing."""
    boundary = draw(st.sampled_from(("b0und", "x" * 70, "")))
    parts = draw(
        st.lists(
            st.tuples(
                st.sampled_from(("file", "File", "upload", "", "file\x00")),
                st.sampled_from(('; filename="a.csv"', '; filename=""', "", '; filename="../../x.csv"')),
                st.binary(max_size=200),
            ),
            max_size=3,
        )
    )
    chunks = [
        f'--{boundary}\r\nContent-Disposition: form-data; name="{name}"{filename}\r\n\r\n'.encode()
        + payload
        + b"\r\n"
        for name, filename, payload in parts
    ]
    body = b"".join(chunks) + (f"--{boundary}--\r\n".encode() if draw(st.booleans()) else b"")
    return body, f"multipart/form-data; boundary={boundary}"


@settings(PROFILE, max_examples=API_EXAMPLES * 6)
@given(
    request=st.one_of(
        st.tuples(st.binary(max_size=2048), st.sampled_from(_CONTENT_TYPES)),
        multipart_bodies(),
    ),
    model=st.one_of(st.none(), st.sampled_from(("tiny-FTIN", "nope", "", "../x", "x" * 300, "ü"))),
    run_id=st.one_of(st.none(), st.text(max_size=80)),
)
def test_predict_arbitrary_requests_never_fail_the_server(
    request, model, run_id, api, case_counter, hard_timeout
):
    body, content_type = request
    params = {k: v for k, v in (("model", model), ("run_id", run_id)) if v is not None}
    # bytes: a non-ASCII header value goes out as latin-1, as a careless client would send it
    headers = {"content-type": content_type.encode("latin-1")} if content_type else {}
    with hard_timeout(HARD_LIMIT_S, "POST /predict with arbitrary bytes"):
        response = api.post("/predict", content=body, headers=headers, params=params)
    case_counter.add("POST /predict arbitrary", str(response.status_code))
    _check_4xx(response)  # none of these bodies is a usable recording


def test_implausible_values_are_422_through_every_door(api):
    """Found by the fuzzer: ``1e308`` in a gyro cell was a 500 through the CSV doors and a 200 with a
    trajectory of nulls through the JSON door; all three now answer 422 naming the sample."""
    n = 150
    t_s = [i / 100 for i in range(n)]
    gyro = [[0.0, 0.0, 0.1] for _ in range(n)]
    gyro[5][0] = 1e308
    acc = [[0.0, 0.0, 9.81] for _ in range(n)]
    lines = ["t,gyro_x,gyro_y,gyro_z,acc_x,acc_y,acc_z"]
    lines += [",".join(map(repr, [t, *g, *a])) for t, g, a in zip(t_s, gyro, acc, strict=True)]
    data = ("\n".join(lines) + "\n").encode()
    for door in ("multipart", "text/csv"):
        detail = _check_4xx(_post_csv(api, data, door))
        assert "line 7, column 'gyro_x'" in detail and "implausible" in detail, detail
    response = api.post("/predict", json={"t_s": t_s, "gyro_rad_s": gyro, "acc_m_s2": acc})
    detail = _check_4xx(response)
    assert "sample 5, column 'gyro_rad_s[0]'" in detail and "implausible" in detail, detail
