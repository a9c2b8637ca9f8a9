//! `[certificate]`: who and what a measurement is for, and which rig made it, as the
//! certificate of measurement states them (ISO/IEC 17025 §7.8.2: the customer, the item, the
//! certificate's unique identification, the person authorising it, the equipment). Every key
//! is optional; the page says "not given" for a missing one.

use serde::{Deserialize, Serialize};

/// `[certificate]`: the measurement's and the rig's identification.
#[derive(Clone, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CertificateConfig {
    /// The certificate's number (unique in the lab's register).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub number: Option<String>,
    /// The customer the measurement is made for.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub customer: Option<String>,
    /// The item measured: the payload's or vehicle's identification (a VIN, a part number).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub item: Option<String>,
    /// The operator who made the measurement.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub operator: Option<String>,
    /// The rig's identification in the lab.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig_id: Option<String>,
    /// The rig's serial number.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rig_serial: Option<String>,
}

impl CertificateConfig {
    /// The fields as (key, label, value) in the page's order.
    pub fn fields(&self) -> [(&'static str, &'static str, Option<&str>); 6] {
        [
            ("number", "certificate number", self.number.as_deref()),
            ("customer", "customer", self.customer.as_deref()),
            ("item", "item measured", self.item.as_deref()),
            ("operator", "operator", self.operator.as_deref()),
            ("rig_id", "rig", self.rig_id.as_deref()),
            (
                "rig_serial",
                "rig serial number",
                self.rig_serial.as_deref(),
            ),
        ]
    }
}
