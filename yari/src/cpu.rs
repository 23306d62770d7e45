//! The CPU features this build was compiled for (`.cargo/config.toml` asks for x86-64-v3:
//! AVX2, FMA, BMI2), checked when a binary starts so that an older CPU gets one readable line
//! instead of an illegal-instruction signal somewhere later.

/// `Err` with a message naming what the build needs when this CPU lacks a feature the build
/// was compiled to use; `Ok` on any other architecture or build.
pub fn check() -> Result<(), String> {
    #[cfg(target_arch = "x86_64")]
    {
        let mut missing = Vec::new();
        if cfg!(target_feature = "avx2") && !std::arch::is_x86_feature_detected!("avx2") {
            missing.push("AVX2");
        }
        if cfg!(target_feature = "fma") && !std::arch::is_x86_feature_detected!("fma") {
            missing.push("FMA");
        }
        if cfg!(target_feature = "bmi2") && !std::arch::is_x86_feature_detected!("bmi2") {
            missing.push("BMI2");
        }
        if !missing.is_empty() {
            return Err(format!(
                "this build needs an x86-64-v3 CPU and this one lacks {}; rebuild with \
                 RUSTFLAGS=\"-C target-cpu=x86-64\"",
                missing.join(", ")
            ));
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn the_machine_that_built_it_runs_it() {
        assert_eq!(super::check(), Ok(()));
    }
}
