"""Pure frame codecs: bytes in, values out, no I/O. Pinned by golden-byte tests."""
