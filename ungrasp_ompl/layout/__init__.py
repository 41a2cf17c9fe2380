"""Layouts: thin pieces put down one after another into a frame on the table. ``model`` reads a
layout (YAML) and holds its frame and pieces; ``tiler`` finds the order, manipulation planes and
plans that put every piece into its frame."""

from .model import Layout
from .tiler import Tiling, TilingOptions, tile

__all__ = ["Layout", "Tiling", "TilingOptions", "tile"]
