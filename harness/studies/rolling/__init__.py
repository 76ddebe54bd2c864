"""The rolling-disk study (``harness rolling-study``)."""
