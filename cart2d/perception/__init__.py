"""What the cart sees: its camera's frames (mjpeg), and what the gateway makes of them."""
