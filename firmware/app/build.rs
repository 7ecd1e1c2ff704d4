//! Links with the top-level `memory.x` (STM32F405RG) and defmt's linker script.
fn main() {
    let out = std::path::PathBuf::from(std::env::var("OUT_DIR").unwrap());
    std::fs::copy("../../memory.x", out.join("memory.x")).unwrap();
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=../../memory.x");
    println!("cargo:rustc-link-arg-bins=-Tdefmt.x");
}
