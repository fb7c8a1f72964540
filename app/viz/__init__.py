"""The viser 3D scene of the dashboard and the pure array helpers it draws from."""
