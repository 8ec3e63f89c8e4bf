"""firmware_stub."""
