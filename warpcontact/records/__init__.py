"""What the studies read and write: a case and its checks, the checks of a solved state, summaries
and result files, progress lines (docs/architecture.md)."""
