// Placeholder: implemented by the lang/ work.
