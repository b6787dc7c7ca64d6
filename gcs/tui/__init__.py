"""The operator console (Textual): live against an aPad (`vil gcs`) or from a recorded run (`vil replay`)."""
