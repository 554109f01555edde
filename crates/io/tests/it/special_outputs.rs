//! Regression (a probe wrote `--out /dev/null`): the atomic write renamed its temporary file over the
//! path, and the machine's `/dev/null` became a regular file (every later `> /dev/null` and rustc's
//! reads of it broke). A path that is not a regular file is written into as it is.

use std::io::Read;
use std::path::Path;

use shipid_io::write::write_atomic;

/// A named pipe at `path` (by the system's `mkfifo`), or `None` where there is none.
fn fifo(path: &Path) -> Option<()> {
    let made = std::process::Command::new("mkfifo")
        .arg(path)
        .status()
        .ok()?;
    made.success().then_some(())
}

#[test]
fn writing_to_a_named_pipe_writes_through_it_and_leaves_it_a_pipe() {
    use std::os::unix::fs::FileTypeExt;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("out.csv");
    if fifo(&path).is_none() {
        panic!("mkfifo is needed for this test (coreutils)");
    }
    let reader_path = path.clone();
    let reader = std::thread::spawn(move || {
        let mut got = Vec::new();
        std::fs::File::open(&reader_path)
            .unwrap()
            .read_to_end(&mut got)
            .unwrap();
        got
    });
    write_atomic(&path, b"t,u\n0,1\n").unwrap();
    // Checked before waiting for the reader: a replaced pipe has no writer, and its reader would
    // wait forever.
    let kind = std::fs::symlink_metadata(&path).unwrap().file_type();
    assert!(kind.is_fifo(), "the pipe was replaced: {kind:?}");
    assert_eq!(reader.join().unwrap(), b"t,u\n0,1\n");
    // Nothing else appeared beside it (no temporary file).
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1);
}

#[test]
fn writing_a_regular_file_still_replaces_it_whole() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.toml");
    std::fs::write(&path, "old contents that are longer").unwrap();
    write_atomic(&path, b"new").unwrap();
    assert_eq!(std::fs::read(&path).unwrap(), b"new");
}
