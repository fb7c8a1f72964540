"""The upload page, its static files and the offline API docs (app/api/routes/pages.py)."""

from __future__ import annotations

from fastapi.testclient import TestClient


def test_upload_page_and_static_files_are_served(client: TestClient) -> None:
    page = client.get("/")
    assert page.status_code == 200 and page.headers["content-type"].startswith("text/html")
    assert "FTIN Studio" in page.text and "/static/app.js" in page.text
    for asset in ("/static/app.js", "/static/plot.js", "/static/style.css"):
        assert client.get(asset).status_code == 200
    # Nothing on the page may come from the internet.
    assert "http://" not in page.text.replace("http://www.w3.org", "")
    assert "https://" not in page.text


def test_favicon_is_served(client: TestClient) -> None:
    icon = client.get("/favicon.ico")
    assert icon.status_code == 200 and icon.headers["content-type"] == "image/x-icon"
    assert icon.content[:4] == b"\x00\x00\x01\x00"  # an ICO file


def test_docs_page_works_offline(client: TestClient) -> None:
    page = client.get("/docs")
    assert page.status_code == 200 and "swagger-ui-bundle.js" in page.text
    assert "cdn." not in page.text and "https://" not in page.text
    for asset in ("swagger-ui-bundle.js", "swagger-ui.css"):
        assert client.get(f"/static-offline-docs/{asset}").status_code == 200
    assert client.get("/redoc").status_code == 404


def test_openapi_documents_both_predict_bodies(client: TestClient) -> None:
    assert client.get("/docs").status_code == 200
    spec = client.get("/openapi.json").json()
    content = spec["paths"]["/predict"]["post"]["requestBody"]["content"]
    assert {"multipart/form-data", "application/json", "text/csv"} <= set(content)
    assert "t_s" in content["application/json"]["schema"]["properties"]
    assert "/sequences/{sequence_id}/predict" in spec["paths"]
