//! pbrt-v4 scene files, read as pbrt-v4 reads them: [`lexer`] (tokens with
//! line and column), [`params`] (typed parameter lists whose unread
//! parameters are errors) and [`parser`] (the directives and the graphics
//! state, into a [`PbrtScene`] of entities that keep their transforms and
//! positions).
//!
//! ```
//! use penumbra_scene::pbrt::{parse_str, MaterialRef};
//! use std::path::Path;
//!
//! let scene = parse_str(
//!     r#"LookAt 0 0 5  0 0 0  0 1 0
//!        Camera "perspective" "float fov" 45
//!        WorldBegin
//!        Material "diffuse" "rgb reflectance" [0.8 0.2 0.2]
//!        AttributeBegin
//!          Translate 0 1 0
//!          Shape "sphere" "float radius" 0.5
//!        AttributeEnd"#,
//!     Path::new("scene.pbrt"),
//!     Path::new("."),
//! )
//! .unwrap();
//! let sphere = &scene.shapes[0];
//! assert_eq!(sphere.entity.kind, "sphere");
//! assert_eq!(sphere.entity.params.float("radius", 1.0).unwrap(), 0.5);
//! assert_eq!(sphere.material, MaterialRef::Anonymous(Some(0)));
//! assert_eq!(sphere.world_from_object.w_axis.y, 1.0);
//! ```

pub mod lexer;
pub mod params;
pub mod parser;
pub mod translate;

pub use params::{ParamList, ParamType, SpectrumValue};
pub use parser::{
    parse_file, parse_str, CameraEntity, Entity, InstanceDefinition, InstanceUse, LightEntity, MaterialRef, PbrtScene,
    ShapeEntity, TextureEntity,
};

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DMat4, DVec3};
    use std::path::Path;

    fn parse(s: &str) -> crate::Result<PbrtScene> {
        parse_str(s, Path::new("t.pbrt"), Path::new("."))
    }

    fn close(a: DMat4, b: DMat4) -> bool {
        a.abs_diff_eq(b, 1e-12)
    }

    #[test]
    fn transforms_compose_as_pbrt() {
        // Each directive post-multiplies the CTM: points are scaled, then rotated, then translated.
        let s = parse(
            "WorldBegin\nTranslate 1 2 3\nRotate 90 0 0 1\nScale 2 2 2\nShape \"sphere\"\n\
             Identity\nTransform [1 0 0 0  0 1 0 0  0 0 1 0  4 5 6 1]\nShape \"sphere\"\n\
             ConcatTransform [2 0 0 0  0 2 0 0  0 0 2 0  0 0 0 1]\nShape \"sphere\"",
        )
        .unwrap();
        let m = s.shapes[0].world_from_object;
        let p = m.transform_point3(DVec3::new(1.0, 0.0, 0.0));
        assert!((p - DVec3::new(1.0, 4.0, 3.0)).length() < 1e-12, "{p}");
        // Transform's sixteen numbers are column by column: the translation is last.
        assert!(close(s.shapes[1].world_from_object, DMat4::from_translation(DVec3::new(4.0, 5.0, 6.0))));
        let p = s.shapes[2].world_from_object.transform_point3(DVec3::ONE);
        assert!((p - DVec3::new(6.0, 7.0, 8.0)).length() < 1e-12, "{p}");
    }

    #[test]
    fn look_at_is_pbrts_camera_from_world() {
        let s = parse("LookAt 0 0 -5  0 0 0  0 1 0\nCamera \"perspective\"\nWorldBegin").unwrap();
        let c = s.camera.unwrap().camera_from_world;
        // The target lies on the camera's +z axis, 5 units ahead; up is +y.
        let t = c.transform_point3(DVec3::ZERO);
        assert!((t - DVec3::new(0.0, 0.0, 5.0)).length() < 1e-12, "{t}");
        let u = c.transform_vector3(DVec3::Y);
        assert!((u - DVec3::Y).length() < 1e-12, "{u}");
        // Left-handed: world +x (to the right, seen from z = -5 looking at +z) is camera +x.
        let r = c.transform_vector3(DVec3::X);
        assert!((r - DVec3::X).length() < 1e-12, "{r}");
    }

    #[test]
    fn attributes_and_transform_blocks_restore_state() {
        let s = parse(
            "WorldBegin\nMaterial \"diffuse\"\nAttributeBegin\nMaterial \"conductor\"\nTranslate 1 0 0\n\
             ReverseOrientation\nAreaLightSource \"diffuse\" \"rgb L\" [1 1 1]\nShape \"disk\"\nAttributeEnd\n\
             TransformBegin\nTranslate 0 1 0\nMaterial \"dielectric\"\nTransformEnd\nShape \"sphere\"",
        )
        .unwrap();
        let (a, b) = (&s.shapes[0], &s.shapes[1]);
        assert_eq!(a.material, MaterialRef::Anonymous(Some(1)));
        assert!(a.reverse_orientation && a.area_light.is_some());
        assert_eq!(a.world_from_object.w_axis.x, 1.0);
        // TransformEnd restores only the transform: the dielectric stays.
        assert_eq!(b.material, MaterialRef::Anonymous(Some(2)));
        assert!(!b.reverse_orientation && b.area_light.is_none());
        assert_eq!(b.world_from_object, DMat4::IDENTITY);
        assert_eq!(s.materials[1].kind, "conductor");
    }

    #[test]
    fn named_materials_textures_instances_and_coordinate_systems() {
        let s = parse(
            "LookAt 0 0 0  0 0 1  0 1 0\nCamera \"perspective\"\nWorldBegin\n\
             Texture \"checks\" \"spectrum\" \"checkerboard\" \"float uscale\" 8\n\
             MakeNamedMaterial \"red\" \"string type\" \"diffuse\" \"texture reflectance\" \"checks\"\n\
             NamedMaterial \"red\"\nObjectBegin \"thing\"\nShape \"sphere\"\nObjectEnd\n\
             Translate 3 0 0\nObjectInstance \"thing\"\nCoordSysTransform \"camera\"\nShape \"disk\"",
        )
        .unwrap();
        assert_eq!(s.named_materials["red"].kind, "diffuse");
        assert_eq!(s.named_materials["red"].params.texture("reflectance").unwrap().as_deref(), Some("checks"));
        assert_eq!(s.textures[0].entity.kind, "checkerboard");
        let def = &s.instance_definitions["thing"];
        assert!(matches!(&def.shapes[0].material, MaterialRef::Named(n, _) if n == "red"));
        assert_eq!(s.instances[0].world_from_instance.w_axis.x, 3.0);
        assert!(close(s.shapes[0].world_from_object, s.camera.unwrap().camera_from_world.inverse()));
    }

    #[test]
    fn parameters_are_typed_and_unread_ones_are_errors() {
        let s = parse(
            "WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1 0 0 0 1 0] \"integer indices\" [0 1 2]\n\
             \"bool flip\" true \"spectrum eta\" \"metal-Cu-eta\" \"blackbody L\" 3000 \"float typo\" 1",
        )
        .unwrap();
        let p = &s.shapes[0].entity.params;
        assert_eq!(p.triples("P", ParamType::Point3).unwrap().unwrap().len(), 3);
        assert_eq!(p.ints("indices").unwrap().unwrap(), vec![0, 1, 2]);
        assert!(p.bool("flip", false).unwrap());
        assert_eq!(p.spectrum("eta").unwrap().unwrap().0, SpectrumValue::Named("metal-Cu-eta".into()));
        assert_eq!(p.spectrum("L").unwrap().unwrap().0, SpectrumValue::Blackbody(3000.0));
        let e = p.check_unused("Shape \"trianglemesh\"").unwrap_err().to_string();
        assert!(e.contains("t.pbrt:3:") && e.contains("\"float typo\""), "{e}");
        // The wrong type is named.
        let e = p.ints("P").unwrap_err().to_string();
        assert!(e.contains("t.pbrt:2:") && e.contains("integer") && e.contains("point3"), "{e}");
    }

    #[test]
    fn errors_name_line_and_what_to_do() {
        let cases = [
            ("WorldBegin\nShape \"sphere\" \"float radius\" [1 x]", "t.pbrt:2:", "'x' is not a number"),
            ("WorldBegin\nShape \"sphere\" \"flot radius\" 1", "t.pbrt:2:", "unknown parameter type 'flot'"),
            ("WorldBegin\nShape \"sphere\" \"float radius\" [1", "t.pbrt:2:", "without its ']'"),
            ("WorldBegin\nShape \"sphere\" \"float radius\" nan", "t.pbrt:2:", "not a finite number"),
            ("WorldBegin\nShape \"sphere\" \"float r\" 1 \"float r\" 2", "t.pbrt:2:", "given twice"),
            ("WorldBegin\nShap \"sphere\"", "t.pbrt:2:1", "unknown directive 'Shap'"),
            ("Shape \"sphere\"", "t.pbrt:1:1", "only allowed after WorldBegin"),
            ("WorldBegin\nCamera \"perspective\"", "t.pbrt:2:1", "only allowed before WorldBegin"),
            ("WorldBegin\nAttributeEnd", "t.pbrt:2:1", "without a matching begin"),
            ("WorldBegin\nAttributeBegin\nTransformEnd", "t.pbrt:3:1", "closes the AttributeBegin at line 2"),
            ("Translate 1 2", "t.pbrt:1:1", "Translate takes 3 numbers"),
            ("WorldBegin\nCoordSysTransform \"nope\"", "t.pbrt:2:19", "no coordinate system named \"nope\""),
            ("WorldBegin\nMakeNamedMaterial \"m\" \"rgb reflectance\" [1 1 1]", "t.pbrt:2:1", "\"string type\""),
            ("WorldBegin\nObjectBegin \"a\"\nObjectBegin \"b\"", "t.pbrt:3:1", "close it with ObjectEnd"),
            (
                "WorldBegin\nObjectBegin \"a\"\nAreaLightSource \"diffuse\"\nShape \"disk\"",
                "t.pbrt:4:1",
                "area light in object",
            ),
            (
                "ActiveTransform EndTime\nTranslate 1 0 0\nActiveTransform All\nCamera \"perspective\"",
                "t.pbrt:4:1",
                "motion blur",
            ),
            ("WorldBegin\nShape \"trianglemesh\" \"point3 P\" [0 0 0 1]", "t.pbrt:2:", "not a multiple of 3"),
            ("WorldBegin\nShape \"sphere\" \"spectrum s\" [300 1 200 2]", "t.pbrt:2:", ""),
            ("LookAt 0 0 0  0 0 0  0 1 0", "t.pbrt:1:1", "LookAt"),
            ("WorldBegin\nInclude \"does/not/exist.pbrt\"", "t.pbrt:2:9", "cannot read"),
        ];
        for (src, at, what) in cases {
            let e = match parse(src) {
                Ok(s) if src.contains("spectrum s") => {
                    // Decreasing wavelengths: found when the spectrum is read.
                    s.shapes[0].entity.params.spectrum("s").unwrap_err().to_string()
                }
                Ok(_) => panic!("accepted: {src}"),
                Err(e) => e.to_string(),
            };
            assert!(e.contains(at) && e.contains(what), "{src:?}: {e}");
        }
    }

    #[test]
    fn includes_resolve_against_the_main_files_directory_and_cycles_stop() {
        let dir = std::env::temp_dir().join(format!("penumbra-pbrt-inc-{}", std::process::id()));
        std::fs::create_dir_all(dir.join("sub")).unwrap();
        std::fs::write(dir.join("main.pbrt"), "WorldBegin\nInclude \"sub/geo.pbrt\"\nShape \"disk\"\n").unwrap();
        // Relative to the main file's directory, not to sub/.
        std::fs::write(dir.join("sub/geo.pbrt"), "Translate 0 0 1\nImport \"sub/more.pbrt\"\n").unwrap();
        std::fs::write(dir.join("sub/more.pbrt"), "Shape \"sphere\"\n").unwrap();
        let s = parse_file(&dir.join("main.pbrt")).unwrap();
        assert_eq!(s.shapes.len(), 2);
        assert_eq!(s.shapes[0].entity.loc.file.file_name().unwrap(), "more.pbrt");
        // Transforms set in an included file stay in effect after it.
        assert_eq!(s.shapes[1].world_from_object.w_axis.z, 1.0);
        std::fs::write(dir.join("loop.pbrt"), "Include \"loop.pbrt\"\n").unwrap();
        let e = parse_file(&dir.join("loop.pbrt")).unwrap_err().to_string();
        assert!(e.contains("loop.pbrt:1:9") && e.contains("includes itself"), "{e}");
        std::fs::write(dir.join("bin.pbrt"), b"WorldBegin\n\xff\xfe").unwrap();
        let e = parse_file(&dir.join("bin.pbrt")).unwrap_err().to_string();
        assert!(e.contains("invalid UTF-8 at byte 11"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }

    #[test]
    fn gzipped_files_are_read() {
        use std::io::Write;
        let dir = std::env::temp_dir().join(format!("penumbra-pbrt-gz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let mut z = flate2::write::GzEncoder::new(Vec::new(), flate2::Compression::default());
        z.write_all(b"WorldBegin\nShape \"sphere\"\n").unwrap();
        std::fs::write(dir.join("s.pbrt.gz"), z.finish().unwrap()).unwrap();
        assert_eq!(parse_file(&dir.join("s.pbrt.gz")).unwrap().shapes.len(), 1);
        std::fs::write(dir.join("bad.pbrt.gz"), b"not gzip").unwrap();
        let e = parse_file(&dir.join("bad.pbrt.gz")).unwrap_err().to_string();
        assert!(e.contains("not a valid gzip file"), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
