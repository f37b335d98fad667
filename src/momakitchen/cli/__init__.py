"""The ``momakitchen`` console script."""
