//! The library's error type, and its mapping to a gRPC status at the service boundary.

use tonic::{Code, Status};

/// What went wrong in REM.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// The request is malformed (bad id, count 0, relative program path ...).
    #[error("invalid request: {0}")]
    Invalid(String),
    /// The program is not on the daemon's allow-list.
    #[error("program {0:?} is not on the allow-list of host {1}")]
    NotAllowed(String, String),
    /// The caller may not do this (an argument or environment rule, another owner's job).
    #[error("{0}")]
    Refused(String),
    /// A limit of the daemon is reached (processes, queued bytes, checkpoint quota ...).
    #[error("limit reached: {0}")]
    Limit(String),
    /// No such process, job or host.
    #[error("not found: {0}")]
    NotFound(String),
    /// Fewer eligible hosts than processes asked for.
    #[error("cannot place {wanted} process(es): only {eligible} eligible host(s) ({detail})")]
    NotEnoughHosts {
        /// Processes asked for.
        wanted: u32,
        /// Hosts that could take one.
        eligible: u32,
        /// Why the others cannot.
        detail: String,
    },
    /// A message is larger than the relay's limit.
    #[error("message of {size} bytes exceeds the limit of {limit} bytes")]
    TooLarge {
        /// The message's size in bytes.
        size: usize,
        /// The limit in bytes.
        limit: usize,
    },
    /// A host did not answer.
    #[error("host {host} is unreachable: {reason}")]
    Unreachable {
        /// The host's name or address.
        host: String,
        /// What the transport said.
        reason: String,
    },
    /// The daemon is shutting down and takes no new work.
    #[error("the daemon is shutting down")]
    ShuttingDown,
    /// Starting the OS process failed.
    #[error("cannot start {program}: {reason}")]
    Spawn {
        /// The program.
        program: String,
        /// What the OS said.
        reason: String,
    },
    /// A write from a controller older than the one that owns the job now.
    #[error("{0}")]
    Fenced(String),
    /// Configuration is missing or wrong.
    #[error("configuration: {0}")]
    Config(String),
    /// The relay stream ended.
    #[error("the relay connection is closed")]
    Closed,
    /// A file or socket operation failed.
    #[error("i/o: {0}")]
    Io(#[from] std::io::Error),
    /// A daemon answered with an error status.
    #[error("{:?}: {}", .0.code(), .0.message())]
    Rpc(#[from] Status),
    /// A connection could not be made or broke.
    #[error("transport: {0}")]
    Transport(#[from] tonic::transport::Error),
}

/// Most bytes of a status message: it travels in an HTTP/2 header, and a peer's HTTP/2 stack
/// closes the whole connection (with every relay link on it) over a header block too large.
pub const MAX_STATUS_MESSAGE: usize = 1024;

/// `text` cut to [`MAX_STATUS_MESSAGE`] bytes.
fn bounded(mut text: String) -> String {
    if text.len() > MAX_STATUS_MESSAGE {
        let mut end = MAX_STATUS_MESSAGE;
        while !text.is_char_boundary(end) {
            end -= 1;
        }
        text.truncate(end);
        text.push_str("...");
    }
    text
}

/// REM's result type.
pub type Result<T, E = Error> = std::result::Result<T, E>;

impl Error {
    /// The gRPC status this error is reported as.
    pub fn to_status(&self) -> Status {
        let code = match self {
            Error::Invalid(_) => Code::InvalidArgument,
            Error::NotAllowed(..) | Error::Refused(_) => Code::PermissionDenied,
            Error::Limit(_) => Code::ResourceExhausted,
            Error::NotFound(_) => Code::NotFound,
            Error::NotEnoughHosts { .. } => Code::FailedPrecondition,
            Error::Fenced(_) => Code::Aborted,
            Error::TooLarge { .. } => Code::ResourceExhausted,
            Error::Unreachable { .. } | Error::ShuttingDown | Error::Closed => Code::Unavailable,
            Error::Spawn { .. } | Error::Io(_) | Error::Transport(_) | Error::Config(_) => {
                Code::Internal
            }
            Error::Rpc(status) => {
                return Status::new(status.code(), bounded(status.message().to_string()))
            }
        };
        Status::new(code, bounded(self.to_string()))
    }

    /// The gRPC code, if this error came from or maps to one.
    pub fn code(&self) -> Code {
        self.to_status().code()
    }

    /// True when a daemon refused the write because the job belongs to a newer controller
    /// (or has ended): the writer must stand down.
    pub fn is_fenced(&self) -> bool {
        self.code() == Code::Aborted
    }

    /// True when a limit refused the request for now (`RESOURCE_EXHAUSTED`): every render
    /// slot held, say; the same request may succeed later.
    pub fn is_exhausted(&self) -> bool {
        self.code() == Code::ResourceExhausted
    }

    /// True when the daemon is gone: no answer ([`is_transport`](Self::is_transport)) or the
    /// relay stream closed.
    pub fn is_connection_lost(&self) -> bool {
        self.is_transport() || matches!(self, Error::Closed)
    }

    /// True when no daemon answered (connection refused, closed or broken, a TLS mismatch),
    /// as opposed to a daemon's answer with an error status.
    pub fn is_transport(&self) -> bool {
        match self {
            Error::Transport(_) => true,
            Error::Rpc(s) => std::error::Error::source(s).is_some(),
            _ => false,
        }
    }

    /// The innermost error of the chain ("Connection refused (os error 111)", "connection
    /// closed") rather than four layers of "transport error": one line for a person.
    pub fn root_cause(&self) -> String {
        let mut cur: &(dyn std::error::Error + 'static) = self;
        while let Some(next) = cur.source() {
            cur = next;
        }
        cur.to_string()
    }
}

impl From<Error> for Status {
    fn from(e: Error) -> Status {
        e.to_status()
    }
}
