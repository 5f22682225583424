"""/docs and /redoc work without internet (issue 15): their pages load Swagger UI and ReDoc from
the gateway itself (cart2d/server/api_docs.py), never from a CDN. The browser's side, with every
request off this machine refused, is web/tests/api-docs.spec.ts."""

from __future__ import annotations

from html.parser import HTMLParser
from pathlib import Path

import pytest

from tests.support.server import Rig


class References(HTMLParser):
    """Every src and href of a page."""

    def __init__(self) -> None:
        super().__init__()
        self.found: list[str] = []

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        self.found += [value for name, value in attrs if name in ("src", "href") and value]


def references(html: str) -> list[str]:
    parser = References()
    parser.feed(html)
    return parser.found


@pytest.mark.parametrize("page", ["/docs", "/redoc"])
def test_the_docs_pages_reference_no_other_host(rig: Rig, page: str) -> None:
    answer = rig.client.get(page)
    assert answer.status_code == 200 and answer.headers["content-type"].startswith("text/html")
    assert "://" not in answer.text  # no CDN, no web fonts: no address off this gateway at all
    # and what the viewers would fetch on their own (ReDoc's logo) the browser must not fetch
    assert "default-src 'self'" in answer.headers["content-security-policy"]
    found = references(answer.text)
    assert any(ref.endswith(".js") for ref in found)
    for ref in found:
        assert ref.startswith("/") and not ref.startswith("//"), ref
        asset = rig.client.get(ref)
        assert asset.status_code == 200 and asset.content, ref


def test_the_docs_assets_need_no_token_off_loopback(tmp_path: Path) -> None:
    """A gateway bound to the network asks a token for changes only: the docs are GETs."""
    rig = Rig(tmp_path, bind_host="0.0.0.0", token="a-secret-token")
    try:
        for path in (
            "/docs",
            "/redoc",
            "/docs-assets/swagger-ui-bundle.js",
            "/docs-assets/redoc.standalone.js",
        ):
            assert rig.client.get(path).status_code == 200, path
    finally:
        rig.close()
