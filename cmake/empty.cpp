// Keeps a library with no sources yet a valid static library target.
