//! Builds the replay input from `../shared/data` (or `GNSS_DATA_DIR`; without it, the simulated
//! drive) with host-sim's generator, and puts the top-level `memory.x` on the link path.
fn main() {
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap());
    let data = host_sim::input::data_dir();
    println!("cargo:rerun-if-env-changed=GNSS_DATA_DIR");
    println!("cargo:rerun-if-changed={}", data.display());
    let (bytes, desc) = host_sim::qemu_input::generate(&data).unwrap_or_else(|e| panic!("generating the QEMU input: {e}"));
    std::fs::write(out.join("input.bin"), &bytes).unwrap();
    std::fs::write(out.join("input.txt"), desc).unwrap();
    std::fs::copy("../../memory.x", out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../../memory.x");
}
