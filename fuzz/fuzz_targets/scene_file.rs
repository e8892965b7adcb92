//! The CLI's scene-file parser (`corofem_cli::scene_file`, the library part
//! of the `corofem-cli` package) on arbitrary text. It accepts a scene or returns an error that
//! names the file; what it accepts, the core accepts too (the CLI must never
//! pass on a value the core would refuse).

#![no_main]

use std::path::Path;

use corofem_cli::scene_file;
use libfuzzer_sys::fuzz_target;

const NAME: &str = "fuzz.toml";

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    match scene_file::parse(text, NAME, Path::new("/nonexistent")) {
        Err(e) => assert!(
            e.0.starts_with(NAME),
            "error without the file name: {}",
            e.0
        ),
        Ok(spec) => {
            spec.material
                .validate()
                .expect("the CLI passed a material the core refuses");
            spec.settings
                .validate()
                .expect("the CLI passed settings the core refuses");
            if let Some(g) = spec.ground {
                assert!(
                    g.normalized().is_some(),
                    "the CLI passed a ground the core refuses"
                );
            }
            if let Some(tool) = &spec.tool {
                assert!(tool.stiffness >= 0.0 && tool.stiffness.is_finite());
                for t in [0.0, 0.5 * tool.path.end_time(), tool.path.end_time(), 1e30] {
                    assert!(tool.path.offset(t).iter().all(|x| x.is_finite()));
                }
            }
            for f in &spec.forces {
                assert!(f.total.iter().all(|x| x.is_finite()));
            }
            assert!(spec.every >= 1);
            assert!(spec.dt > 0.0 && spec.dt.is_finite());
        }
    }
});
