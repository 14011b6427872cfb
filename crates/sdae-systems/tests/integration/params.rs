//! Parameter structs as they come from scene files: round trips, missing fields named,
//! errors for unknown ones, masses as a number or a list.

use sdae_systems::{
    ChainMoleculeParams, FiberParams, Masses, RigidTriatomicParams, chain_molecule, rigid_triatomic,
};

fn round_trip<T>(value: &T) -> T
where
    T: serde::Serialize + serde::de::DeserializeOwned,
{
    serde_json::from_str(&serde_json::to_string(value).unwrap()).unwrap()
}

#[test]
fn defaults_round_trip() {
    let chain = ChainMoleculeParams::default();
    assert_eq!(round_trip(&chain), chain);
    let triatomic = RigidTriatomicParams::default();
    assert_eq!(round_trip(&triatomic), triatomic);
    let fiber = FiberParams::default();
    assert_eq!(round_trip(&fiber), fiber);
}

#[test]
fn missing_fields_are_named_and_masses_take_both_forms() {
    let e = serde_json::from_str::<ChainMoleculeParams>(r#"{"atoms": 5}"#).unwrap_err();
    assert!(e.to_string().contains("missing field `bond_length`"), "{e}");
    let e = serde_json::from_str::<FiberParams>(r#"{"beads": 5}"#).unwrap_err();
    assert!(e.to_string().contains("missing field `segment`"), "{e}");
    let p: ChainMoleculeParams = serde_json::from_str(
        r#"{"atoms": 5, "bond_length": 1, "masses": [1, 2, 3, 2, 1], "friction": 1,
            "temperature": 1, "angle": {"stiffness": 4, "equilibrium": 2}}"#,
    )
    .unwrap();
    assert_eq!(p.masses, Masses::PerParticle(vec![1.0, 2.0, 3.0, 2.0, 1.0]));
    assert_eq!((p.angle.stiffness, p.angle.equilibrium), (4.0, 2.0));
    // The torsion table is optional: off.
    assert_eq!(p.torsion.stiffness, 0.0);
    chain_molecule(&p).unwrap();
    let p: RigidTriatomicParams = serde_json::from_str(
        r#"{"bond_lengths": [1, 1, 1], "masses": 2.5, "friction": 1, "temperature": 1,
            "trap": {"stiffness": 1, "center": [0, 0, 0]}}"#,
    )
    .unwrap();
    assert_eq!(p.masses, Masses::Uniform(2.5));
    rigid_triatomic(&p).unwrap();
    let mut text = serde_json::to_value(FiberParams::default()).unwrap();
    text["air"] = serde_json::json!({"wind": [0, 2, 0]});
    let p: FiberParams = serde_json::from_value(text).unwrap();
    assert_eq!(p.air.wind, [0.0, 2.0, 0.0]);
    assert_eq!(p.air.shear, [[0.0; 3]; 3]);
}

#[test]
fn unknown_fields_are_errors() {
    for text in [
        r#"{"atom": 5}"#,
        r#"{"atoms": 5, "angle": {"stifness": 1}}"#,
    ] {
        let e = serde_json::from_str::<ChainMoleculeParams>(text).unwrap_err();
        assert!(e.to_string().contains("unknown field"), "{e}");
    }
    let e = serde_json::from_str::<FiberParams>(r#"{"air": {"speed": 1}}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field"), "{e}");
    let e = serde_json::from_str::<RigidTriatomicParams>(r#"{"trap": {"k": 1}}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field"), "{e}");
}
