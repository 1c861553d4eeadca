"""The numerics: devices, recorded launches, the elastic operator, the model, a state's fields, the
memory a grid needs, the stress below the surface and the yield check (docs/architecture.md)."""
