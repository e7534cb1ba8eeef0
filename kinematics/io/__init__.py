"""Reading and writing what users bring: URDF, DH tables (and their URDF), the bundled
catalogue, poses given as data, trajectory files, and the product's pose output."""

from .catalogue import Catalogue, default_catalogue
from .dh_table import DHTable, load_table, loads_table, model_from_table, table_from_dict, table_to_dict, table_to_urdf
from .urdf import load_urdf, parse_urdf

__all__ = ["Catalogue", "DHTable", "default_catalogue", "load_table", "loads_table", "load_urdf", "model_from_table",
           "parse_urdf", "table_from_dict", "table_to_dict", "table_to_urdf"]
