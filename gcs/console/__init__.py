"""The operator console: the world thread that runs it and the Textual screens (the model it shows: `gcs.view`)."""
