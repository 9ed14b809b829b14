"""Plan the measurements: test geometry and session skeletons."""
