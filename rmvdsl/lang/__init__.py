"""The language's shared leaves: source spans, diagnostics and their one wording per
code, how they are rendered, exact numbers, the registry of built-ins, exit codes."""
