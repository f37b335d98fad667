"""The benchmark report (``momakitchen benchmark``): :mod:`.benchmark` runs it, :mod:`.tables`
and :mod:`.figures` write its tables and pictures."""
