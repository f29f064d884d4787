"""The ``geomech`` command line, and the schema of its JSON documents."""

from ._args import SCHEMA, schema
from .main import cli, main

__all__ = ["SCHEMA", "cli", "main", "schema"]
