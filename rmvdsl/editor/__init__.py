"""What an editor is served: the workspace (open documents over the disk, the
fast and solver stages, what stands at a position), mentions of names, and the
language server (`rmv lsp`), thin over the workspace."""
