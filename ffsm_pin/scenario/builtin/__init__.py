"""Built-in scenario files (the paper's cases)."""
