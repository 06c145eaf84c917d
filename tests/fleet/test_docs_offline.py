"""The fleet server's /docs and /redoc work on a site network without internet."""

from __future__ import annotations

from pathlib import Path

import httpx

from fleet.app import create_app


def _client(tmp_path: Path) -> httpx.AsyncClient:
    app = create_app(f"sqlite:///{tmp_path / 'fleet.db'}", monitors=False)
    return httpx.AsyncClient(transport=httpx.ASGITransport(app=app), base_url="http://fleet")


class TestOfflineDocs:
    async def test_swagger_ui_and_redoc_load_their_assets_from_this_server(
            self, tmp_path: Path) -> None:
        """No CDN in the pages; every script and style they name is served here, without a
        token (like /docs and /openapi.json)."""
        async with _client(tmp_path) as client:
            for page, assets in (("/docs", ("swagger-ui-bundle.js", "swagger-ui.css")),
                                 ("/redoc", ("redoc.standalone.js",))):
                html = (await client.get(page)).text
                assert "cdn." not in html and "fonts.googleapis" not in html
                for asset in assets:
                    assert f"/docs-assets/{asset}" in html
                    reply = await client.get(f"/docs-assets/{asset}")
                    assert reply.status_code == 200 and len(reply.content) > 1000

    async def test_the_assets_are_not_in_the_api_document(self, tmp_path: Path) -> None:
        async with _client(tmp_path) as client:
            paths = (await client.get("/openapi.json")).json()["paths"]
        assert not [p for p in paths if p.startswith(("/docs", "/redoc"))]
