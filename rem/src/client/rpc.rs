//! The generated gRPC client of `proto/rem.proto` with the cluster secret attached to every
//! call: what [`crate::client::rem_client::RemClient`] and [`crate::client::relay::Relay`] both talk through.

use tonic::service::interceptor::InterceptedService;
use tonic::transport::Channel;

use crate::auth::secret::SendSecret;
use crate::wire::proto::rem_client;

/// The generated client, with the secret attached to every call (for raw access).
pub type RemRpc = rem_client::RemClient<InterceptedService<Channel, SendSecret>>;
