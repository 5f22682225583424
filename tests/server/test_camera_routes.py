"""The camera's routes over a Source (server/routes/camera.py): a feed fake enough to count its
subscribers, no camera, no gateway."""

from __future__ import annotations

from collections.abc import Callable
from types import SimpleNamespace

from fastapi import FastAPI
from fastapi.testclient import TestClient

from cart2d.server.camera import CameraWatchers
from cart2d.server.routes import camera


def test_a_feed_is_watched_once_however_often_the_camera_is_read() -> None:
    # Each read made a Watchers (dict.setdefault's default), which subscribed to the feed for good:
    # a panel polling /api/camera added a subscriber a poll, each called for every frame.
    sinks: list[Callable[..., object]] = []

    def subscribe(sink: Callable[..., object]) -> Callable[[], None]:
        sinks.append(sink)
        return lambda: None

    feed = SimpleNamespace(subscribe=subscribe, shown=lambda: None)
    app = FastAPI()
    app.state.source = SimpleNamespace(camera_feed=lambda: feed, camera_view=lambda: {"camera": True})
    app.state.camera_watchers = CameraWatchers()
    app.router.routes.extend(camera.router.routes)
    client = TestClient(app)
    for _ in range(5):
        assert client.get("/api/camera").json() == {"camera": True, "viewers": 0}
    assert len(sinks) == 1


def test_without_a_camera_the_frame_is_a_404_with_the_sources_sentence() -> None:
    app = FastAPI()
    words = "this recording holds no camera frames"
    app.state.source = SimpleNamespace(
        camera_feed=lambda: None, camera_view=lambda: {"camera": False, "message": words}
    )
    app.state.camera_watchers = CameraWatchers()
    app.router.routes.extend(camera.router.routes)
    client = TestClient(app)
    assert client.get("/api/camera").json() == {"camera": False, "message": words}
    for path in ("/api/camera/frame.jpg", "/api/camera/stream"):
        answer = client.get(path)
        assert answer.status_code == 404 and answer.json() == {"detail": words}
