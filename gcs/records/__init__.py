"""What a run leaves behind and reads back: its folder, events, checkpoints and the replay of a recorded run."""
