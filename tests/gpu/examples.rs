use super::util::*;

#[test]
fn examples_run_headless_and_save_their_view() {
    check_gpu_adapter().unwrap_or_else(|hint| panic!("{hint}"));
    let translucent = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets/suite/translucent.gltf");
    let scene = translucent.to_str().unwrap();
    for (name, frames, extra) in [
        ("toggle", "12", None),
        ("cornell", "12", None),
        ("bunny", "12", None),
        ("pool", "3", None),
        ("fox", "3", None),
        // Lit only through diffuse transmission, which the example reads as rppm does.
        ("scene", "12", Some(scene)),
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
        assert!(
            lit > pixels.len() / 10,
            "{name}: the saved view is nearly black"
        );
    }
}
