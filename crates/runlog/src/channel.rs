//! One channel of the log as the log and the live view both declare it: topic, schema name,
//! JSON schema and encoding ([`ChannelSpec`], [`Encoding`]), and the Foxglove SDK's schemas of
//! the well-known messages ([`well_known_schema`]).

use anyhow::{Context, Result};

use crate::schema::Schema;

/// One channel of the log.
#[derive(Clone, Debug)]
pub struct ChannelSpec {
    /// Topic, e.g. `/sensors`.
    pub topic: &'static str,
    /// Schema name, e.g. `stewart.SensorFrame` or `foxglove.SceneUpdate`.
    pub schema_name: &'static str,
    /// The JSON schema of its messages; for a protobuf channel, of the message decoded to JSON
    /// (the proto field names, a non-finite number as `null`), which docs/log-schema.md
    /// documents and the tests check the protobuf schema against.
    pub schema: Schema,
    /// How its messages are encoded.
    pub encoding: Encoding,
}

impl ChannelSpec {
    /// The schema record's data: the JSON schema document of a JSON channel, the
    /// `FileDescriptorSet` of a protobuf one. The log and a live view (crate `live`) advertise
    /// the same bytes.
    pub fn schema_data(&self) -> Result<Vec<u8>> {
        Ok(match self.encoding {
            Encoding::Json => serde_json::to_vec(&self.schema.document(self.schema_name))?,
            Encoding::Protobuf => crate::proto::descriptor::file_descriptor_set_bytes(),
            Encoding::Foxglove => well_known_schema(self.schema_name)
                .with_context(|| {
                    format!(
                        "{}: {} is not a well-known Foxglove schema of this log",
                        self.topic, self.schema_name
                    )
                })?
                .data
                .into_owned(),
        })
    }
}

/// The Foxglove SDK's schema (name, `protobuf`, `FileDescriptorSet`) of a well-known message
/// the log writes, by its schema name.
pub fn well_known_schema(name: &str) -> Option<foxglove::Schema> {
    use foxglove::messages::{FrameTransform, SceneUpdate};
    use foxglove::Encode as _;
    [FrameTransform::get_schema(), SceneUpdate::get_schema()]
        .into_iter()
        .flatten()
        .find(|s| s.name == name)
}

/// A channel's message encoding.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Encoding {
    /// Message encoding `json`, schema encoding `jsonschema`: where people read the log.
    Json,
    /// Message encoding `protobuf`, schema encoding `protobuf` (the `FileDescriptorSet` of
    /// [`crate::proto::descriptor`]): the 1 kHz channels, compact and cheap to decode.
    Protobuf,
    /// Message and schema encoding `protobuf`, the schema being the Foxglove SDK's own
    /// descriptor of a well-known message ([`well_known_schema`]): the 3D channels, as the
    /// SDK's types ([`crate::foxglove`]).
    Foxglove,
}

impl Encoding {
    /// MCAP's name of the message encoding.
    pub fn message_encoding(self) -> &'static str {
        match self {
            Self::Json => "json",
            Self::Protobuf | Self::Foxglove => "protobuf",
        }
    }

    /// MCAP's name of the schema encoding.
    pub fn schema_encoding(self) -> &'static str {
        match self {
            Self::Json => "jsonschema",
            Self::Protobuf | Self::Foxglove => "protobuf",
        }
    }
}
