//! Flags that cannot apply are refused, never ignored: input flags without
//! a city file (the embedded default city is lon/lat GeoJSON with heights),
//! with exit status 2, a message naming the flag, and no output file.

use crate::common::{citypvs, stderr};

#[test]
fn input_flags_without_a_city_file_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    for (flags, named) in [
        (&["--metric"][..], "--metric"),
        (&["--format", "cityjson"][..], "--format"),
        (&["--default-height", "12"][..], "--default-height"),
    ] {
        let mut args = vec!["bake", "-q", "-o", "out.pvs"];
        args.extend_from_slice(flags);
        let out = citypvs(dir.path(), &args);
        let err = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{flags:?}: {err}");
        assert!(
            err.contains(named) && err.contains("no") && err.contains("default city"),
            "{flags:?}: {err}"
        );
        assert_eq!(err.lines().count(), 1, "{err}");
        assert!(!dir.path().join("out.pvs").exists(), "{flags:?}");
    }
}
