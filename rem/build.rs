//! Compiles `proto/rem.proto` with protox (pure Rust, no `protoc`) and tonic-prost-build.
fn main() -> Result<(), Box<dyn std::error::Error>> {
    let proto_dir = concat!(env!("CARGO_MANIFEST_DIR"), "/../proto");
    let proto = format!("{proto_dir}/rem.proto");
    println!("cargo:rerun-if-changed={proto}");
    let files = protox::compile([proto.as_str()], [proto_dir])?;
    tonic_prost_build::configure()
        .build_server(true)
        .build_client(true)
        // Maps in field order, so that a message encodes to the same bytes on both sides
        // (peer calls sign a digest of their body).
        .btree_map(".")
        // A chunk's bytes are a slice of the caller's buffer, shared, not copied; and a
        // daemon passes them on to a peer the same way.
        .bytes(".rem.v1.PutChunkRequest.data")
        .compile_fds(files)?;
    Ok(())
}
