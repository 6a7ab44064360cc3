"""The FMI side: the plumbing between an FMU's binary and a simulator, and the loader the binary runs."""
