// Placeholder: implemented by the stdlib/ work.
