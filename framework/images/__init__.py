"""Image inputs: reading photos (PNG/JPEG, grey, colour, alpha) into tensors."""
