//! Compiles `proto/sunray.proto` (the SunRay III messages and checkpoint) with protox (pure
//! Rust, no `protoc`) and tonic-prost-build, messages only: they travel inside REM envelopes.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let proto_dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../proto");
    let proto = format!("{proto_dir}/sunray.proto");
    println!("cargo:rerun-if-changed={proto}");
    let files = protox::compile([proto.as_str()], [proto_dir])?;
    tonic_prost_build::configure()
        .build_server(false)
        .build_client(false)
        .compile_fds(files)?;
    Ok(())
}
