"""Bundle pose refinement of all objects and cameras of a static multi-object sequence."""
