//! Mitsuba 3 XML reader.
