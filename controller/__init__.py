"""Controller side of the G1 stack: policies, command inputs, run loop, CLI."""
