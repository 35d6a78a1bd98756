//! PLY reader.
