"""Python side of the SMA host tools: CLI, build of the C++ helpers, plots, serial console."""
