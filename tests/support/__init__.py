"""What the tests share: rigs (a simulator, a gateway, a test camera, ser2net), fakes and waits.
Test modules import from here, never from each other."""
