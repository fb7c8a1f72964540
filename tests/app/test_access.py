"""Who may use the API (app/access.py): the one token from other machines (bearer, the cookie a
``?token=`` URL sets, a push URL's token), the ``Host`` allow-list, the cross-site check, and no
token in the access log of a real uvicorn server. A client on another machine is simulated by
TestClient's client address, and under uvicorn by ``X-Forwarded-For``, which uvicorn trusts from
127.0.0.1 only (its default ``--forwarded-allow-ips``)."""

from __future__ import annotations

import logging
import os
import re
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import httpx
import pandas as pd
import pytest
from fastapi.testclient import TestClient
from hypothesis import given, settings
from hypothesis import strategies as st

from app.access import COOKIE_NAME, AccessMiddleware, AccessPolicy, is_local, is_this_machine, redact_query
from app.main import create_app
from app.serve import serve_in_thread
from app.settings import Settings
from tests.app.routes.helpers import detail, upload
from tests.utils.paths import REPO_ROOT

TOKEN = "s3cret-token-for-tests"
REMOTE = ("203.0.113.7", 50000)  # a documentation address: on no machine
SHORT_ROWS = 300


@pytest.fixture(scope="module")
def short_csv(sample_frame: pd.DataFrame) -> bytes:
    return sample_frame.iloc[:SHORT_ROWS].to_csv(index=False).encode()


@pytest.fixture(scope="module")
def app_with_token(make_settings: Callable[..., Settings]):
    return create_app(make_settings(token=TOKEN))


@pytest.fixture(scope="module")
def local(app_with_token) -> Iterator[TestClient]:
    with TestClient(app_with_token) as client:  # runs the lifespan; "testclient" is this process
        yield client


@pytest.fixture
def remote(app_with_token, local: TestClient) -> TestClient:
    """Another machine, on the app ``local`` started (no second lifespan; a fresh cookie jar each test)."""
    return TestClient(app_with_token, client=REMOTE)


@pytest.fixture(scope="module")
def run_id(local: TestClient, short_csv: bytes) -> str:
    response = upload(local, short_csv)
    assert response.status_code == 200, response.text
    return response.json()["run_id"]


def bearer(token: str = TOKEN) -> dict[str, str]:
    return {"Authorization": f"Bearer {token}"}


def test_another_machine_needs_the_token_on_every_route_but_health(
    remote: TestClient, run_id: str, short_csv: bytes
) -> None:
    for response in (
        remote.get("/runs"),
        remote.get(f"/runs/{run_id}/trajectory.csv"),
        remote.get(f"/runs/{run_id}/trajectory.gpx"),
        upload(remote, short_csv),
        remote.get("/"),
        remote.get("/openapi.json"),
        remote.get("/live/info"),
        remote.get("/runs", headers=bearer("wrong-token-1")),
    ):
        assert response.status_code == 401, (response.request.url, response.text)
        assert "token" in detail(response) and TOKEN not in response.text
        assert response.headers["www-authenticate"] == "Bearer"
    assert remote.get("/health").status_code == 200
    assert remote.get("/runs", headers=bearer()).status_code == 200
    assert remote.get(f"/runs/{run_id}/trajectory.csv", headers=bearer()).status_code == 200
    answer = remote.post("/predict", headers=bearer(), files={"file": ("walk.csv", short_csv, "text/csv")})
    assert answer.status_code == 200, answer.text


def test_every_route_in_the_schema_but_health_is_closed_to_another_machine(
    app_with_token, remote: TestClient
) -> None:
    """Every operation the app documents (and the pages, files and docs it does not), asked with no
    token from another machine: 401 before any route runs."""
    asked = {"/health": 200, "/static/app.js": 401, "/docs": 401, "/favicon.ico": 401}
    for path, item in app_with_token.openapi()["paths"].items():
        for method in item:
            url = re.sub(r"\{[^}]+\}", "abcdef", path)
            status = remote.request(method.upper(), url).status_code
            assert status == (200 if path == "/health" else 401), (method, path, status)
            asked[f"{method} {path}"] = status
    for url, status in asked.items():
        if url.startswith("/"):
            assert remote.get(url).status_code == status, url
    assert len(asked) > 25


def test_a_token_url_sets_a_cookie_and_drops_the_token(remote: TestClient, run_id: str) -> None:
    login = remote.get("/runs", params={"token": TOKEN, "limit": 5}, follow_redirects=False)
    assert login.status_code == 302 and login.headers["location"] == "/runs?limit=5"
    cookie = login.headers["set-cookie"]
    assert cookie.startswith(f"{COOKIE_NAME}=") and "HttpOnly" in cookie and "samesite=lax" in cookie.lower()
    assert TOKEN not in cookie  # an HMAC of it
    assert remote.get("/runs").status_code == 200  # the cookie from now on
    assert remote.get(f"/runs/{run_id}/trajectory.csv").status_code == 200
    assert remote.get("/").status_code == 200
    remote.cookies.set(COOKIE_NAME, "0" * 64)  # a cookie from an earlier start's token
    stale = remote.get("/runs")
    assert stale.status_code == 401 and "out of date" in detail(stale)
    wrong = remote.get("/runs", params={"token": "not-the-token"}, follow_redirects=False)
    assert wrong.status_code == 401 and "set-cookie" not in wrong.headers


def test_the_push_urls_token_lets_a_phone_push(app_with_token, remote: TestClient) -> None:
    body = {"messageId": 0, "sessionId": "s", "deviceId": "d", "payload": []}
    assert remote.post("/live/sensorlogger", json=body).status_code == 401
    pushed = remote.post("/live/sensorlogger", params={"token": TOKEN}, json=body)
    assert pushed.status_code == 200, pushed.text  # a POST uses the token; no redirect
    assert remote.get("/live/sessions", params={"token": TOKEN}).status_code == 200  # a GET: redirected
    app_with_token.state.services.live.end_all()


def test_this_machine_needs_no_token(app_with_token, local: TestClient, run_id: str) -> None:
    assert local.get("/runs").status_code == 200
    loopback = TestClient(app_with_token, client=("127.0.0.1", 40000))
    assert loopback.get(f"/runs/{run_id}/trajectory.csv").status_code == 200
    assert TestClient(app_with_token, client=("::1", 40000)).get("/runs").status_code == 200
    shown_wrong = local.get("/runs", headers=bearer("wrong-token-2"))  # shown: then it must be right
    assert shown_wrong.status_code == 401


def test_only_this_machines_names_are_answered(
    local: TestClient, make_settings: Callable[..., Settings]
) -> None:
    evil = local.get("/runs", headers={"Host": "evil.example"})
    assert evil.status_code == 400 and "FTIN_ALLOWED_HOSTS" in detail(evil)
    assert local.get("/health", headers={"Host": "evil.example:8000"}).status_code == 400
    for host in ("localhost:8000", "127.0.0.1", "[::1]:8000", "studio.localhost", socket.gethostname()):
        assert local.get("/health", headers={"Host": host}).status_code == 200, host
    for host in ("127.0.0.1:notaport", "", "evil.example@127.0.0.1"):
        assert local.get("/health", headers={"Host": host}).status_code == 400, host
    # TestClient's own name is allowed in tests by FTIN_ALLOWED_HOSTS (tests/conftest.py), nowhere else.
    with TestClient(create_app(make_settings(allowed_hosts=[]))) as bare:
        assert bare.get("/health").status_code == 400
        assert bare.get("/health", headers={"Host": "127.0.0.1:8000"}).status_code == 200
    with TestClient(create_app(make_settings(allowed_hosts=["*"]))) as anyname:
        assert anyname.get("/health", headers={"Host": "evil.example"}).status_code == 200


def test_a_cross_site_page_cannot_change_anything(
    local: TestClient, short_csv: bytes, make_settings: Callable[..., Settings]
) -> None:
    files = {"file": ("walk.csv", short_csv, "text/csv")}
    for origin in ("http://evil.example", "null", "http://testserver:8080", "https://testserver"):
        refused = local.post("/predict", headers={"Origin": origin}, files=files)
        assert refused.status_code == 403 and "cross-site" in detail(refused), origin
    plain = local.post("/predict", headers={"Origin": "http://evil.example"}, content=b"t,gyro_x\n")
    assert plain.status_code == 403  # text/plain: what a form or fetch sends without asking
    assert local.get("/runs", headers={"Origin": "http://evil.example"}).status_code == 200  # no change
    same = local.post("/predict", headers={"Origin": "http://testserver"}, files=files)
    assert same.status_code == 200, same.text  # the page itself
    assert local.post("/predict", files=files).status_code == 200  # no Origin: curl, a phone app
    with TestClient(create_app(make_settings(cors_origins=["http://allowed.example"]))) as cors:
        allowed = cors.post("/predict", headers={"Origin": "http://allowed.example"}, files=files)
        assert allowed.status_code == 200, allowed.text


def test_this_machine_is_loopback_or_its_own_addresses() -> None:
    assert is_local(None) and is_local("127.0.0.1") and is_local("::1") and is_local("testclient")
    assert not is_local("203.0.113.7") and not is_local("192.0.2.1") and not is_local("some.name")
    assert is_this_machine("127.0.0.2") and not is_this_machine("0.0.0.0")
    own = socket.getaddrinfo(socket.gethostname(), None, socket.AF_INET)[0][4][0]
    assert is_this_machine(own)  # a browser here opening the LAN address needs no token


_TEXT = st.text(st.characters(min_codepoint=0, max_codepoint=255), max_size=60)
_HEADER = st.one_of(_TEXT, st.sampled_from(["127.0.0.1:8000", "evil.example", "[::1]", "http://x", "null"]))


@settings(max_examples=300, deadline=None)
@given(
    host=st.none() | _HEADER,
    origin=st.none() | _HEADER,
    cookie=st.none() | _TEXT.map(lambda v: f"{COOKIE_NAME}={v}"),
    auth=st.none() | _TEXT | _TEXT.map(lambda v: f"Bearer {v}"),
    query=_TEXT,
    method=st.sampled_from(["GET", "HEAD", "POST", "DELETE", "OPTIONS", "PATCH"]),
    client=st.sampled_from(["127.0.0.1", "203.0.113.7", "testclient", "::1", "not an address"]),
)
def test_any_headers_get_an_answer_not_an_error(host, origin, cookie, auth, query, method, client) -> None:
    """Whatever a client sends in the headers the check reads, it passes or is refused: never raises."""
    headers = [
        (k.encode(), v.encode("latin-1"))
        for k, v in (("host", host), ("origin", origin), ("cookie", cookie), ("authorization", auth))
        if v is not None
    ]
    scope = {
        "type": "http",
        "method": method,
        "path": "/runs",
        "scheme": "http",
        "query_string": query.encode("latin-1"),
        "headers": headers,
        "client": (client, 5000),
        "server": ("127.0.0.1", 8000),
    }
    refusal = AccessMiddleware(None, POLICY)._check(scope)  # type: ignore[arg-type]
    assert refusal is None or refusal.status_code in (302, 400, 401, 403)
    if refusal is None and client == "203.0.113.7":  # another machine got in: it showed the token
        assert TOKEN in (auth or "") + query or POLICY.cookie_value in (cookie or "")


POLICY = AccessPolicy.from_settings(Settings(token=TOKEN, allowed_hosts=[]))


def test_query_secrets_are_redacted() -> None:
    assert (
        redact_query("/live/sensorlogger?token=abc&model=x") == "/live/sensorlogger?token=[redacted]&model=x"
    )
    assert redact_query("/a?%74oken=abc;api_key=k&x=1") == "/a?%74oken=[redacted];api_key=[redacted]&x=1"
    assert redact_query("/runs?limit=5") == "/runs?limit=5" and redact_query("/runs") == "/runs"


def test_the_old_live_token_name_still_works(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("FTIN_LIVE_TOKEN", "old-name-token")
    assert Settings().token == "old-name-token"
    monkeypatch.setenv("FTIN_TOKEN", "new-name-token")
    assert Settings().token == "new-name-token"
    monkeypatch.delenv("FTIN_TOKEN")
    monkeypatch.delenv("FTIN_LIVE_TOKEN")
    policy = AccessPolicy.from_settings(Settings())
    assert policy.token_generated and len(policy.token) >= 32  # generated: never an open server


class _Lines(logging.Handler):
    def __init__(self) -> None:
        super().__init__()
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(self.format(record))


def test_the_token_never_reaches_the_access_log(make_settings: Callable[..., Settings]) -> None:
    """A real uvicorn server (access log on): a remote client's token URL, push URL and bearer
    requests are logged, the token never."""
    captured = _Lines()
    access_log = logging.getLogger("uvicorn.access")
    server = serve_in_thread(
        create_app(make_settings(token=TOKEN)), name="test-uvicorn-access", log_level="info"
    )
    access_log.addHandler(captured)
    try:
        remote = {"X-Forwarded-For": REMOTE[0]}
        with httpx.Client(
            base_url=server.base_url, headers=remote, timeout=30, follow_redirects=True
        ) as client:
            assert client.get("/runs").status_code == 401
            login = client.get("/runs", params={"token": TOKEN, "limit": 3})
            assert login.status_code == 200 and login.history[0].status_code == 302
            push = client.post("/live/sensorlogger", params={"token": TOKEN}, json={"payload": []})
            assert push.status_code in (200, 422), push.text
            assert client.get("/health", params={"token": TOKEN}).status_code == 200
    finally:
        access_log.removeHandler(captured)
        assert server.stop(), "uvicorn did not stop"
    log = "\n".join(captured.lines)
    assert REMOTE[0] in log and "token=[redacted]" in log and "/live/sensorlogger" in log, log
    assert TOKEN not in log


def _free_port() -> int:
    with socket.socket() as sock:
        sock.bind(("127.0.0.1", 0))
        return sock.getsockname()[1]


@pytest.mark.slow  # one `uvicorn app.main:app` start (~10 s on a shared 2-core machine)
def test_a_lan_bind_without_a_token_makes_one_and_prints_the_url(
    checkpoint_dir: Path, tmp_path: Path
) -> None:
    """``uvicorn app.main:app --host 0.0.0.0`` as the docs say to start it for a phone, no token set: it
    prints the URL to open, the token works from another machine, and no log line holds it."""
    env = {k: v for k, v in os.environ.items() if not k.startswith("FTIN_")}
    env.update(
        FTIN_CHECKPOINT_DIR=str(checkpoint_dir),
        FTIN_VISER_ENABLED="false",
        FTIN_SCENE_FIRST_RUN="false",
        FTIN_RUNS_DIR=str(tmp_path / "runs"),
    )
    port = _free_port()
    process = subprocess.Popen(
        [sys.executable, "-m", "uvicorn", "app.main:app", "--host", "0.0.0.0", "--port", str(port)],
        cwd=REPO_ROOT,
        env=env,
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
    )
    lines: list[str] = []
    reader = threading.Thread(target=lambda: lines.extend(process.stdout or ()), daemon=True)
    reader.start()
    base = f"http://127.0.0.1:{port}"
    remote = {"X-Forwarded-For": REMOTE[0]}
    try:
        deadline = time.monotonic() + 90
        while True:
            try:
                assert httpx.get(f"{base}/health", headers=remote, timeout=2).status_code == 200
                break
            except httpx.HTTPError:
                if process.poll() is not None or time.monotonic() > deadline:
                    raise AssertionError("app did not start:\n" + "".join(lines)) from None
                time.sleep(0.2)
        printed = re.findall(rf"http://\S+:{port}/\?token=(\S+)", "".join(lines))
        assert printed, "".join(lines)
        token = printed[0]
        with httpx.Client(base_url=base, headers=remote, timeout=30, follow_redirects=True) as phone:
            assert phone.get("/runs").status_code == 401
            login = phone.get("/", params={"token": token})
            assert login.status_code == 200 and login.history[0].status_code == 302
            assert phone.get("/runs").status_code == 200  # the cookie
            assert phone.get("/runs", headers={"Authorization": f"Bearer {token}"}).status_code == 200
        assert httpx.get(f"{base}/runs", timeout=10).status_code == 200  # this machine: none needed
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)
        reader.join(10)
    output = "".join(lines)
    assert len(token) >= 32 and "FTIN_TOKEN" in output
    access = [line for line in lines if '"GET /' in line]
    assert any("/?token=[redacted]" in line for line in access), output
    assert output.count(token) == len(printed)  # in the printed URLs to open only
    assert not any(token in line for line in access)
    assert process.returncode == 0 and "Traceback" not in output, output
