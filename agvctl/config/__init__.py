"""Strict loading of TOML files into frozen dataclasses, with one-line errors.

The public file formats (vehicles, trajectories, experiments) are all read through :func:`build`: unknown keys
are rejected with a "did you mean", missing keys and wrong types are named, numbers are checked for the bounds a
field declares with :func:`number`. Every problem raises :class:`~agvctl.errors.ConfigError` whose message is
``"<file>: <key.path>: <problem>"``. A dataclass made in Python checks itself the same way (:func:`check_fields`),
and :func:`document_fields` writes its ``Parameters`` section from the same field declarations.

Plain dataclasses rather than pydantic: the schemas are small, the dependencies fixed, and the loader gives exactly
the one-line messages the CLI promises.

The package's modules: :mod:`~agvctl.config.fields` (declaring, checking and documenting fields),
:mod:`~agvctl.config.loading` (tables into dataclasses), :mod:`~agvctl.config.files` (TOML files in and out),
:mod:`~agvctl.config.overrides` (``--set``).
"""

from __future__ import annotations

from agvctl.config.fields import check_fields, document_fields, number
from agvctl.config.files import (
    MAX_FILE_BYTES,
    MAX_LOG_BYTES,
    check_plain_name,
    dump_toml,
    load_toml,
    read_text,
    to_dict,
)
from agvctl.config.loading import as_file_error, build, build_fields, convert_value, did_you_mean, join_key, renamed
from agvctl.config.overrides import apply_overrides, check_key, override_pairs, parse_override

__all__ = [
    "MAX_FILE_BYTES",
    "MAX_LOG_BYTES",
    "apply_overrides",
    "as_file_error",
    "build",
    "build_fields",
    "check_fields",
    "check_key",
    "check_plain_name",
    "convert_value",
    "did_you_mean",
    "document_fields",
    "dump_toml",
    "join_key",
    "load_toml",
    "number",
    "override_pairs",
    "parse_override",
    "read_text",
    "renamed",
    "to_dict",
]
