//! Wavefront OBJ reader.
