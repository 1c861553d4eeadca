"""The studies: a case's load path, gross slip, approach and retraction, Table 2, sweeps and the
batch engine, the stress study, fits (docs/architecture.md)."""
