"""The FTIN Studio dashboard: REST API, upload page and viser 3D scene (``uvicorn app.main:app``)."""
