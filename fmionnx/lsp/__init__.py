"""The language server (``fmionnx lsp``): diagnostics, completion, hover, definitions, fixes
and renames for system, study and SSD files, from the compiler and the real model interfaces.

Needs the ``lsp`` extra (``pip install -e '.[lsp]'``: pygls); importing this package does
not, so that the CLI can say so.
"""
