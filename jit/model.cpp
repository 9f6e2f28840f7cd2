// Placeholder: implemented by the jit/ work.
