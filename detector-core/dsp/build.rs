//! Selects the Cortex-M DSP-extension kernel for targets that have the extension (ARMv7E-M:
//! Cortex-M4 and M7). `target_feature = "dsp"` is not readable on stable Rust, so the target
//! name decides.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(dsp_ext)");
    let target = std::env::var("TARGET").unwrap_or_default();
    if target.starts_with("thumbv7em") {
        println!("cargo::rustc-cfg=dsp_ext");
    }
}
