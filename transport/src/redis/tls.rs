//! TLS to a Redis server (`rediss://`): the roots that verify the server, from the URL's
//! `tls_ca=PATH` (PEM) or the system's, for both connections — redis-rs's publishing
//! connection and the subscriber's own socket, which speaks TLS through rustls. The server's
//! certificate is always verified, its name included.

use std::sync::Arc;

use rustls::pki_types::pem::PemObject;
use rustls::pki_types::{CertificateDer, ServerName};
use rustls::{ClientConfig, ClientConnection, RootCertStore};

/// The TLS settings of one server.
#[derive(Debug, Clone)]
pub(super) struct Tls {
    config: Arc<ClientConfig>,
    /// The CA file's bytes, for redis-rs (`None`: the system's roots).
    pub(super) root_pem: Option<Vec<u8>>,
}

impl Tls {
    /// TLS trusting the certificates of the PEM file `ca`, or the system's roots.
    pub(super) fn new(ca: Option<&str>) -> Result<Self, String> {
        let mut roots = RootCertStore::empty();
        let root_pem = match ca {
            Some(path) => {
                let pem =
                    std::fs::read(path).map_err(|e| format!("cannot read tls_ca {path:?}: {e}"))?;
                let certs: Vec<CertificateDer<'static>> = CertificateDer::pem_slice_iter(&pem)
                    .collect::<Result<_, _>>()
                    .map_err(|e| format!("tls_ca {path:?} is not PEM certificates: {e}"))?;
                if certs.is_empty() {
                    return Err(format!("tls_ca {path:?} holds no certificate"));
                }
                for cert in certs {
                    roots
                        .add(cert)
                        .map_err(|e| format!("tls_ca {path:?}: {e}"))?;
                }
                Some(pem)
            }
            None => {
                let found = rustls_native_certs::load_native_certs();
                roots.add_parsable_certificates(found.certs);
                if roots.is_empty() {
                    return Err(
                        "no system root certificates; name the server's CA with tls_ca=PATH"
                            .to_owned(),
                    );
                }
                None
            }
        };
        // The crypto provider rustls is built with (ring: the one its features name here).
        let config = ClientConfig::builder()
            .with_root_certificates(roots)
            .with_no_client_auth();
        Ok(Self {
            config: Arc::new(config),
            root_pem,
        })
    }

    /// A client session with the server named `host` (a name or an IP address).
    pub(super) fn session(&self, host: &str) -> std::io::Result<ClientConnection> {
        let invalid = |e: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, e);
        let name = ServerName::try_from(host.to_owned())
            .map_err(|e| invalid(format!("{host:?} is no server name: {e}")))?;
        ClientConnection::new(self.config.clone(), name).map_err(|e| invalid(e.to_string()))
    }
}
