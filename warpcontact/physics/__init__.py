"""The physics: materials, the sphere and the grid, the friction and adhesion laws, the influence
coefficients, the closed-form reference solutions (docs/architecture.md)."""
