//! The tensor reader on the files `tools/make_tensor_files.py` writes
//! (Mitsuba's `tensor_io.write` layout; Mitsuba 3.9.1's `TensorFile` reads
//! `valid.tensor` with the same offsets, types and shapes).

use penumbra_scene::tensor::{write, Dtype, TensorFile};
use std::path::PathBuf;

fn file(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../tests/scenes/tensor").join(name)
}

#[test]
fn valid_file_reads_as_mitsuba_does() {
    let t = TensorFile::open(&file("valid.tensor")).unwrap();
    let names: Vec<&str> = t.fields().iter().map(|f| f.name.as_str()).collect();
    assert_eq!(names, ["description", "values", "flag"]);
    let offsets: Vec<u64> = t.fields().iter().map(|f| f.offset).collect();
    assert_eq!(offsets, [112, 120, 144]);
    let v = t.field("values").unwrap();
    assert_eq!((v.dtype, v.shape.as_slice()), (Dtype::F32, &[2u64, 3][..]));
    assert_eq!(t.f32_data(v).unwrap(), [0.5, -1.0, 2.0, 3.25, 4.0, 1e-3]);
    assert_eq!(t.u8_data(t.field("description").unwrap()).unwrap(), b"hello");
    assert_eq!(t.u8_data(t.field("flag").unwrap()).unwrap(), [1]);
}

#[test]
fn the_writer_matches_the_generator_byte_for_byte() {
    let vals: Vec<u8> = [0.5f32, -1.0, 2.0, 3.25, 4.0, 1e-3].iter().flat_map(|v| v.to_le_bytes()).collect();
    let ours = write(&[
        ("description", Dtype::U8, &[5], b"hello"),
        ("values", Dtype::F32, &[2, 3], &vals),
        ("flag", Dtype::U8, &[1], &[1]),
    ]);
    assert_eq!(ours, std::fs::read(file("valid.tensor")).unwrap());
}

#[test]
fn malformed_files_are_refused_with_the_file_and_offset() {
    for (name, expect) in [
        ("bad_magic.tensor", "byte 0: not a tensor file"),
        (
            "truncated_table.tensor",
            "byte 18: field 'description' (uint8 of shape [5] at byte 112) does not fit in the file's 60 bytes",
        ),
        (
            "truncated_data.tensor",
            "byte 50: field 'values' (float32 of shape [2, 3] at byte 120) does not fit in the file's 141 bytes",
        ),
        ("bad_dtype.tensor", "byte 33: field 'description' has unknown element type 12"),
        ("huge_shape.tensor", "field 'x' (float64 of shape [4611686018427387904, 4] at byte 48) does not fit"),
    ] {
        let err = TensorFile::open(&file(name)).unwrap_err();
        assert!(err.contains(name) && err.contains(expect), "{name}: {err}");
    }
    let short = TensorFile::parse(std::fs::read(file("valid.tensor")).unwrap()[..30].to_vec()).unwrap_err();
    assert!(short.starts_with("byte 14: 3 fields cannot fit in the 12 bytes"), "{short}");
    assert!(TensorFile::open(&file("absent.tensor")).unwrap_err().contains("cannot read"));
}
