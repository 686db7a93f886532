"""Small utilities with no knowledge of the language: bounded caches, on-disk
caches, a deep stack for deep inputs."""
