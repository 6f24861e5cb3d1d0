"""Writing scenes: USD authoring helpers, mesh files to USD through trimesh, and small
in-memory ``Scene`` builders for tests and scripts."""
