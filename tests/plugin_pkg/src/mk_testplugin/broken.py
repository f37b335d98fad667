"""An entry point whose module fails to import."""

import a_module_that_is_not_installed  # noqa: F401

Model = None
