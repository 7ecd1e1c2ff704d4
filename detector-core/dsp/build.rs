//! Selects the Cortex-M DSP-extension kernel for targets that have the extension (ARMv7E-M:
//! Cortex-M4 and M7). `target_feature = "dsp"` is not readable on stable Rust, so the target
//! name decides. The same name says whether there is an FPU (`eabihf`) for `sqrtf`'s
//! `VSQRT.F32`.
fn main() {
    println!("cargo::rustc-check-cfg=cfg(dsp_ext)");
    println!("cargo::rustc-check-cfg=cfg(fpu_sqrt)");
    let target = std::env::var("TARGET").unwrap_or_default();
    if target.starts_with("thumbv7em") {
        println!("cargo::rustc-cfg=dsp_ext");
        // The hard-float ABI means an FPU (FPv4-SP on the M4F, FPv5 on the M7): VSQRT.F32.
        if target.ends_with("eabihf") {
            println!("cargo::rustc-cfg=fpu_sqrt");
        }
    }
}
