"""The command-line front ends: `vil` and its table of commands (`main`), one module per command, the flags'
types they share (`flags`) and the tables they print (`tables`)."""
