"""Runtime shared by the DTC drive stack nodes (parameter schema, node main, lockstep I/O, topics)."""
