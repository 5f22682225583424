"""Foxglove live view and MCAP flight recorder: the gateway's live data on the Foxglove SDK's
built-in message types (channels.py, publisher.py), served to the Foxglove app or Lichtblick over
the SDK's WebSocket server and written to MCAP files (session.py); `cart2d replay` plays a
recording back into the panel (replay.py, replay_app.py)."""

from cart2d.recording.publisher import Publisher
from cart2d.recording.session import Recording, open_recording, session_file_name, start_live_view

__all__ = ["Publisher", "Recording", "open_recording", "session_file_name", "start_live_view"]
