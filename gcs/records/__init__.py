"""What a run leaves behind and reads back: events, checkpoints, replay and reports."""
