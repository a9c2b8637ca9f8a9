//! `[certificate]`: who and what a measurement is for, and which rig made it, as the
//! certificate of measurement states them (ISO/IEC 17025 §7.8.2: the customer, the item, the
//! certificate's unique identification, the person authorising it, the equipment). Every key
//! is optional; the page says "not given" for a missing one.
//!
//! `[[certificate.nominal]]` entries give values the item should have, each with its
//! tolerance; the report then states conformity with each (ISO/IEC 17025 §7.8.6), by the
//! guarded-acceptance decision rule of [`crate::quantities::conformity`].

use serde::{Deserialize, Serialize};

/// `[certificate]`: the measurement's and the rig's identification.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
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
    /// Values the item should have, each with its tolerance.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub nominal: Vec<Nominal>,
}

/// `[[certificate.nominal]]`: a value the item should have and the tolerance around it.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Nominal {
    /// The quantity as the report names it ([`crate::quantities::Quantities::NAMES`]: `mass`,
    /// `com x` … `com z`, `J_C xx` … `J_C yz`), in the frame the results lead with: the
    /// vehicle's when `[vehicle]` is given, else P.
    pub quantity: String,
    /// The nominal value, SI (kg, m, kg·m²).
    pub value: f64,
    /// The tolerance: the item conforms when its value lies within value ± tolerance.
    pub tolerance: f64,
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
