//! Parameter structs as they come from scene files: round trips, defaults for missing fields,
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
fn missing_fields_take_defaults_and_masses_take_both_forms() {
    let p: ChainMoleculeParams = serde_json::from_str(
        r#"{"atoms": 5, "masses": [1, 2, 3, 2, 1], "angle": {"stiffness": 4}}"#,
    )
    .unwrap();
    assert_eq!(p.atoms, 5);
    assert_eq!(p.masses, Masses::PerParticle(vec![1.0, 2.0, 3.0, 2.0, 1.0]));
    assert_eq!(p.angle.stiffness, 4.0);
    assert_eq!(
        p.angle.equilibrium,
        ChainMoleculeParams::default().angle.equilibrium
    );
    assert_eq!(p.temperature, 1.0);
    chain_molecule(&p).unwrap();
    let p: RigidTriatomicParams = serde_json::from_str(r#"{"masses": 2.5}"#).unwrap();
    assert_eq!(p.masses, Masses::Uniform(2.5));
    rigid_triatomic(&p).unwrap();
    let p: FiberParams = serde_json::from_str(r#"{"air": {"wind": [0, 2, 0]}}"#).unwrap();
    assert_eq!(p.air.wind, [0.0, 2.0, 0.0]);
    assert_eq!(p.air.shear, [[0.0; 3]; 3]);
}

#[test]
fn unknown_fields_are_errors() {
    for text in [r#"{"atom": 5}"#, r#"{"angle": {"stifness": 1}}"#] {
        let e = serde_json::from_str::<ChainMoleculeParams>(text).unwrap_err();
        assert!(e.to_string().contains("unknown field"), "{e}");
    }
    let e = serde_json::from_str::<FiberParams>(r#"{"air": {"speed": 1}}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field"), "{e}");
    let e = serde_json::from_str::<RigidTriatomicParams>(r#"{"trap": {"k": 1}}"#).unwrap_err();
    assert!(e.to_string().contains("unknown field"), "{e}");
}
