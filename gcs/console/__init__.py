"""The operator console: the world thread that runs it, the model it shows, and the Textual screens."""
