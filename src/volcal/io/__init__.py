"""Low-level file helpers shared by every reader and writer."""
