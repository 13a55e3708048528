"""The ``task/1`` task-file format, one module a kind, each reading AND writing its kind.

By kind (each imports only the ones above it in this list):

- :mod:`.regions`: contact regions (the format's one module that knows the region kinds).
- :mod:`.hands`: inline hand mappings (links, joints, couplings, fingers, hand regions).
- :mod:`.hand_files`: hands named by file (``{file: hand.yaml}``, ``{urdf: ...}``, ``{mjcf: ...}``).
- :mod:`.task_hands`: a task's ``hand:`` with ``hand_limits_deg`` / ``hand_couplings`` /
  ``hand_regions`` (a built-in hand or a hand file written as its name plus differences).
- :mod:`.objects`: the ``object:`` mapping (regions, solid, display).
- :mod:`.tasks`: whole task mappings; :func:`~.tasks.resolve_hand` (a hand named on the
  command line, possibly by a task file).
- :mod:`.embedded`: the files a task names, carried inside a result.

Shared by all kinds (they import nothing above): :mod:`.schema` (the pydantic models
every mapping is checked with, and the names a file may use), :mod:`.errors`
(:class:`~prehension.errors.InvalidTask` messages that name the file and the field path),
:mod:`.yaml_text` (YAML text to plain data and back) and :mod:`.values` (how numbers are
written so that they read back exactly).

The public entry point is :mod:`prehension.tasks.yaml_io`; its docstring describes the
format.
"""
