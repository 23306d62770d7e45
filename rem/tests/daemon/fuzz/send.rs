//! Sending an input as raw bytes: a pass-through codec ([`RawCodec`]), the call, and what
//! became of it ([`Outcome`]).

use super::credentials::authorize;
use super::inputs::{Input, Rpc};
use super::values::World;
use super::{CALL_DEADLINE, STREAM_READ};
use prost::bytes::{Buf, BufMut};
use tonic::codec::{Codec, DecodeBuf, Decoder, EncodeBuf, Encoder};
use tonic::transport::Channel;
use tonic::{Code, Request, Status};

/// A codec that sends bytes as they are and returns every message's bytes.
#[derive(Clone, Copy, Debug, Default)]
struct RawCodec;

/// [`RawCodec`]'s encoder.
struct RawEncoder;

/// [`RawCodec`]'s decoder.
struct RawDecoder;

impl Encoder for RawEncoder {
    type Item = Vec<u8>;
    type Error = Status;

    fn encode(&mut self, item: Vec<u8>, dst: &mut EncodeBuf<'_>) -> Result<(), Status> {
        dst.put_slice(&item);
        Ok(())
    }
}

impl Decoder for RawDecoder {
    type Item = Vec<u8>;
    type Error = Status;

    fn decode(&mut self, src: &mut DecodeBuf<'_>) -> Result<Option<Vec<u8>>, Status> {
        let mut out = vec![0; src.remaining()];
        src.copy_to_slice(&mut out);
        Ok(Some(out))
    }
}

impl Codec for RawCodec {
    type Encode = Vec<u8>;
    type Decode = Vec<u8>;
    type Encoder = RawEncoder;
    type Decoder = RawDecoder;

    fn encoder(&mut self) -> RawEncoder {
        RawEncoder
    }

    fn decoder(&mut self) -> RawDecoder {
        RawDecoder
    }
}

/// What became of one input.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Outcome {
    /// The call ended with this status (`Ok` for a reply).
    Status(Code),
    /// No answer within [`CALL_DEADLINE`].
    Hung,
}

impl Outcome {
    /// Orders outcomes by status code, hangs last.
    fn rank(self) -> i32 {
        match self {
            Outcome::Status(c) => c as i32,
            Outcome::Hung => i32::MAX,
        }
    }
}

impl PartialOrd for Outcome {
    fn partial_cmp(&self, other: &Self) -> Option<std::cmp::Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Outcome {
    fn cmp(&self, other: &Self) -> std::cmp::Ordering {
        self.rank().cmp(&other.rank())
    }
}

impl std::fmt::Display for Outcome {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Outcome::Status(c) => write!(f, "{c:?}"),
            Outcome::Hung => f.write_str("HUNG"),
        }
    }
}

/// Sends `input` on `channel` and waits for its answer (a stream's is read for
/// [`STREAM_READ`], then dropped); returns the outcome and the status's message.
pub(super) async fn send(channel: Channel, input: &Input, world: &World) -> (Outcome, String) {
    let call = async {
        let mut grpc = tonic::client::Grpc::new(channel).max_decoding_message_size(64 << 20);
        grpc.ready()
            .await
            .map_err(|e| Status::unavailable(format!("channel not ready: {e}")))?;
        let path = input.rpc.path();
        match input.rpc {
            Rpc::Attach => {
                let mut req = Request::new(tokio_stream::iter(input.frames.clone()));
                authorize(&mut req, input, world);
                let mut inbound = grpc.streaming(req, path, RawCodec).await?.into_inner();
                for _ in 0..16 {
                    match tokio::time::timeout(STREAM_READ, inbound.message()).await {
                        Ok(Ok(Some(_))) => {}
                        Ok(Ok(None)) | Err(_) => break,
                        Ok(Err(s)) => return Err(s),
                    }
                }
                Ok(())
            }
            Rpc::Forward => {
                let mut req = Request::new(tokio_stream::iter(input.frames.clone()));
                authorize(&mut req, input, world);
                grpc.client_streaming(req, path, RawCodec).await.map(drop)
            }
            _ => {
                let mut req = Request::new(input.frames[0].clone());
                authorize(&mut req, input, world);
                grpc.unary(req, path, RawCodec).await.map(drop)
            }
        }
    };
    match tokio::time::timeout(CALL_DEADLINE, call).await {
        Ok(Ok(())) => (Outcome::Status(Code::Ok), String::new()),
        Ok(Err(s)) => (Outcome::Status(s.code()), s.message().to_string()),
        Err(_) => (Outcome::Hung, String::new()),
    }
}
