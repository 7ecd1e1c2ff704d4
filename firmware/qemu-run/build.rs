//! Builds the replay input from `../shared/data` (or `GNSS_DATA_DIR`; without it, the simulated
//! drive) with gnss-data's generator, and puts the top-level `memory.x` on the link path.
fn main() {
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let data = gnss_data::input::data_dir();
    println!("cargo:rerun-if-env-changed=GNSS_DATA_DIR");
    println!("cargo:rerun-if-env-changed=CI");
    let seg = data.join("raw/comma2k19_rav4_seg40/processed_log");
    if std::env::var("CI").is_ok_and(|v| v == "true") && !seg.is_dir() {
        panic!("CI=true: the QEMU run must replay the real comma2k19 segment, but {} is missing", seg.display());
    }
    println!("cargo:rerun-if-changed={}", data.display());
    let (bytes, desc) = gnss_data::qemu_input::generate(&data).unwrap_or_else(|e| panic!("generating the QEMU input: {e}"));
    std::fs::write(out.join("input.bin"), &bytes).unwrap();
    std::fs::write(out.join("input.txt"), desc).unwrap();
    std::fs::copy("../../memory.x", out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../../memory.x");
}
