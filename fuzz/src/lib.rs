//! The property both fuzzers check: whatever bytes a scene file holds, parsing it gives a
//! scene or an input error naming the file (and a line inside the text, when it names one);
//! it never panics. A scene that parses also survives being written back and read again.

use grainstat::scene::parse_scene;

/// Check one input; panics (the fuzzers' failure) when the property does not hold.
pub fn check_scene(data: &[u8]) {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match parse_scene(text, "fuzz.toml") {
        Ok(scene) => {
            // What was accepted can be written back, and reads back as the same scene.
            let written = toml::to_string(&scene).expect("an accepted scene serialises");
            match parse_scene(&written, "written.toml") {
                Ok(again) => assert!(again == scene, "the scene changed on the way back"),
                Err(e) => panic!("an accepted scene written back is refused: {e}\n{written}"),
            }
        }
        Err(e) => {
            assert_eq!(e.file, "fuzz.toml", "{e}");
            let lines = text.lines().count().max(1) + 1;
            if let Some(line) = e.line {
                assert!(line >= 1 && line <= lines, "line {line} of {lines}: {e}");
            }
            assert!(!e.to_string().is_empty());
        }
    }
}
