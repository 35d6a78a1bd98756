#!/usr/bin/env python3
"""Write the small tensor files of Penumbra's tensor-reader tests (deterministic).

Usage: python3 tools/make_tensor_files.py

The layout is that of `mitsuba.tensor_io.write` (see crates/scene/src/tensor.rs),
written here with `struct` alone so that no Mitsuba or numpy is needed:

tests/scenes/tensor/valid.tensor: fields 'description' (uint8 [5], b"hello"),
  'values' (float32 [2, 3]: 0.5, -1, 2, 3.25, 4, 0.001), 'flag' (uint8 [1], 1),
  data aligned to 8 bytes.
bad_magic.tensor: valid.tensor with byte 3 changed.
truncated_table.tensor: valid.tensor cut inside the field table (60 bytes).
truncated_data.tensor: valid.tensor without its last 4 bytes.
bad_dtype.tensor: valid.tensor whose first field has element type 12.
huge_shape.tensor: one float64 field of shape [2^62, 4] and no data.
"""
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
OUT = os.path.join(os.path.dirname(HERE), "tests", "scenes", "tensor")

CODES = {"u8": 1, "f32": 10, "f64": 11}


def tensor(fields, align=8):
    """fields: list of (name, dtype code name, shape, data bytes)."""
    out = bytearray(b"tensor_file\0")
    out += struct.pack("<BB", 1, 0)
    out += struct.pack("<I", len(fields))
    offset_at = []
    for name, dtype, shape, _ in fields:
        label = name.encode("utf8")
        out += struct.pack("<H", len(label)) + label
        out += struct.pack("<H", len(shape))
        out += struct.pack("B", CODES[dtype])
        offset_at.append(len(out))
        out += struct.pack("<Q", 0)
        out += struct.pack("<" + "Q" * len(shape), *shape)
    for (_, _, _, data), at in zip(fields, offset_at):
        pos = (len(out) + align - 1) // align * align
        out += b"\0" * (pos - len(out))
        out[at:at + 8] = struct.pack("<Q", pos)
        out += data
    return bytes(out)


def main():
    os.makedirs(OUT, exist_ok=True)
    values = struct.pack("<6f", 0.5, -1.0, 2.0, 3.25, 4.0, 1e-3)
    valid = tensor([
        ("description", "u8", [5], b"hello"),
        ("values", "f32", [2, 3], values),
        ("flag", "u8", [1], b"\x01"),
    ])
    bad_magic = bytearray(valid)
    bad_magic[3] = ord("x")
    bad_dtype = bytearray(valid)
    bad_dtype[18 + 2 + 11 + 2] = 12
    files = {
        "valid.tensor": valid,
        "bad_magic.tensor": bytes(bad_magic),
        "truncated_table.tensor": valid[:60],
        "truncated_data.tensor": valid[:-4],
        "bad_dtype.tensor": bytes(bad_dtype),
        "huge_shape.tensor": tensor([("x", "f64", [1 << 62, 4], b"")]),
    }
    for name, data in files.items():
        with open(os.path.join(OUT, name), "wb") as f:
            f.write(data)
        print(f"wrote {os.path.join(OUT, name)} ({len(data)} bytes)")


if __name__ == "__main__":
    main()
