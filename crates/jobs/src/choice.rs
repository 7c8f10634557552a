//! The closed sets among the jobs' settings: a backbone, a schedule, a pair rule, a zone
//! filter, a compute device. Each is parsed once where it enters (clap on the command line,
//! serde from the TOML of `endoloc run` and from Python keywords) and matched on inside; the
//! spelling of each value is written once, here.

use std::fmt;

/// Defines a choice: the enum, its one spelling per value for every edge (serde, clap,
/// `Display`), and its default.
macro_rules! choice {
    (
        $(#[$meta:meta])*
        pub enum $name:ident {
            $( $(#[$vmeta:meta])* $variant:ident = $text:literal, )+
        }
        default $default:ident
    ) => {
        $(#[$meta])*
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize)]
        #[cfg_attr(feature = "cli", derive(clap::ValueEnum))]
        pub enum $name {
            $(
                $(#[$vmeta])*
                #[serde(rename = $text)]
                #[cfg_attr(feature = "cli", value(name = $text))]
                $variant,
            )+
        }

        impl $name {
            /// The value as it is written in options, TOML and reports.
            pub fn name(self) -> &'static str {
                match self {
                    $( $name::$variant => $text, )+
                }
            }
        }

        impl Default for $name {
            fn default() -> Self {
                $name::$default
            }
        }

        impl fmt::Display for $name {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                f.write_str(self.name())
            }
        }
    };
}

choice! {
    /// The network trunk of the zone classifier.
    pub enum Backbone {
        /// The CPU default: 256x192 input, a stride-4 first layer.
        Compact = "compact",
        /// The paper's GoogLeNet, 224x224x1 (for a GPU).
        GoogLeNet = "googlenet",
    }
    default Compact
}

impl Backbone {
    /// Its configuration with the library's defaults.
    pub fn config(self) -> endoloc_net::backbone::BackboneConfig {
        use endoloc_net::backbone::BackboneConfig;
        match self {
            Backbone::Compact => BackboneConfig::compact(),
            Backbone::GoogLeNet => BackboneConfig::googlenet(),
        }
    }
}

choice! {
    /// A training schedule preset.
    pub enum SchedulePreset {
        /// 150 epochs of 128+128 pairs, batches of 64 pairs sharing images, Adam 1e-3 → 1e-4.
        Fast = "fast",
        /// The paper's: 500 epochs of 128+128 pairs, batches of 128, Adam 1e-3.
        Paper = "paper",
    }
    default Fast
}

impl SchedulePreset {
    /// The schedule.
    pub fn schedule(self) -> endoloc_net::train::Schedule {
        use endoloc_net::train::Schedule;
        match self {
            SchedulePreset::Fast => Schedule::fast(),
            SchedulePreset::Paper => Schedule::paper(),
        }
    }
}

choice! {
    /// Which frames make the training pairs.
    pub enum Pairs {
        /// The paper's: positives share a zone, negatives do not.
        Zone = "zone",
        /// By distance along the training pass (positives a few frames apart, negatives
        /// farther).
        Track = "track",
    }
    default Zone
}

choice! {
    /// The zone a frame is given: the nearest training descriptors' alone, or filtered over
    /// the video.
    pub enum ZoneFilter {
        /// Each frame on its own.
        None = "none",
        /// The HMM's forward (causal) estimate.
        Forward = "forward",
        /// The HMM's most likely path over the whole sequence.
        Viterbi = "viterbi",
        /// The track filter along the training pass (causal; the live default).
        Track = "track",
        /// The track filter smoothed with the frames that follow.
        Smooth = "smooth",
    }
    default Track
}

choice! {
    /// Where the network runs.
    pub enum Device {
        /// `BURN_DEVICE` when set, else the CPU.
        Auto = "auto",
        /// The CPU (burn's `flex` backend); every build has it.
        Cpu = "cpu",
        /// An NVIDIA GPU (builds with the `cuda` feature).
        Cuda = "cuda",
        /// A GPU through wgpu (builds with the `wgpu` feature).
        Wgpu = "wgpu",
    }
    default Cpu
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(serde::Deserialize, serde::Serialize)]
    struct Holder {
        filter: ZoneFilter,
        device: Device,
    }

    #[test]
    fn each_value_reads_and_writes_with_one_spelling() {
        let h: Holder = toml::from_str("filter = \"viterbi\"\ndevice = \"auto\"\n").unwrap();
        assert_eq!((h.filter, h.device), (ZoneFilter::Viterbi, Device::Auto));
        let text = toml::to_string(&h).unwrap();
        assert_eq!(text, "filter = \"viterbi\"\ndevice = \"auto\"\n");
        assert_eq!(Backbone::GoogLeNet.to_string(), "googlenet");
        let err = toml::from_str::<Holder>("filter = \"max\"\ndevice = \"cpu\"\n")
            .err()
            .unwrap()
            .to_string();
        assert!(err.contains("`max`") && err.contains("`smooth`"), "{err}");
    }
}
