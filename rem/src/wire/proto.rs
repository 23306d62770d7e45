//! The generated gRPC types and services (`proto/rem.proto`, package `rem.v1`).
#![allow(clippy::all, missing_docs)]

tonic::include_proto!("rem.v1");
