"""HTTP layer: routers (one per resource), dependencies, error mapping and the upload size limit."""
