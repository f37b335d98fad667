"""A model package outside momakitchen (installed by the plug-in tests)."""
