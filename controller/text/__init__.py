"""Text planning: prompts split into clauses, resolved into behaviour programs, composed and executed."""
