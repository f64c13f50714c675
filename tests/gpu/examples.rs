use super::util::*;

#[test]
fn examples_run_headless_and_save_their_view() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let translucent = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite/translucent.gltf");
    let scene = translucent.to_str().unwrap();
    for (name, frames, extra) in [
        ("toggle", "12", &[][..]),
        ("cornell", "12", &[]),
        ("bunny", "12", &[]),
        // The size the README's frames per second are measured at, scaled down.
        ("pool", "3", &["--width", "128", "--height", "72"]),
        ("fox", "3", &[]),
        // Lit only through diffuse transmission, which the example reads as rppm does.
        ("scene", "12", &[scene]),
    ] {
        let out = temp(&format!("example_{name}.png"));
        let run = Command::new(example_binary(name))
            .args(extra)
            .args(["--headless", "--frames", frames, "--out"])
            .arg(&out)
            .output()
            .unwrap_or_else(|e| panic!("cannot run the {name} example: {e}"));
        assert!(
            run.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let decoder =
            png::Decoder::new(std::io::BufReader::new(std::fs::File::open(&out).unwrap()));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        let lit = pixels[..info.buffer_size()]
            .iter()
            .filter(|&&v| v > 16)
            .count();
        eprintln!(
            "{name}: {}x{}, {lit} lit channel values",
            info.width, info.height
        );
        let size = if extra.len() == 4 {
            (128, 72)
        } else {
            (320, 240)
        };
        assert_eq!((info.width, info.height), size, "{name}: the view's size");
        let stdout = String::from_utf8_lossy(&run.stdout);
        assert!(
            stdout.contains(&format!(" fps at {}×{}", size.0, size.1)),
            "{name}: no frames per second in {stdout:?}"
        );
        assert!(
            lit > pixels.len() / 10,
            "{name}: the saved view is nearly black"
        );
    }
}
