//! The built-in scenes, shipped as TOML files in `scenes/` and compiled into the library.

/// The built-in scenes: (name, file contents).
pub const BUILT_IN: [(&str, &str); 20] = [
    ("pendulum", include_str!("../scenes/pendulum.toml")),
    (
        "spherical-pendulum",
        include_str!("../scenes/spherical-pendulum.toml"),
    ),
    (
        "fast-pendulum",
        include_str!("../scenes/fast-pendulum.toml"),
    ),
    (
        "noisy-pendulum",
        include_str!("../scenes/noisy-pendulum.toml"),
    ),
    (
        "long-pendulum",
        include_str!("../scenes/long-pendulum.toml"),
    ),
    (
        "thermal-pendulum",
        include_str!("../scenes/thermal-pendulum.toml"),
    ),
    (
        "gibbs-pendulum",
        include_str!("../scenes/gibbs-pendulum.toml"),
    ),
    (
        "chain-molecule",
        include_str!("../scenes/chain-molecule.toml"),
    ),
    ("triatomic", include_str!("../scenes/triatomic.toml")),
    ("fiber", include_str!("../scenes/fiber.toml")),
    ("stiff-fiber", include_str!("../scenes/stiff-fiber.toml")),
    (
        "straight-fiber",
        include_str!("../scenes/straight-fiber.toml"),
    ),
    ("drag-fiber", include_str!("../scenes/drag-fiber.toml")),
    ("long-fiber", include_str!("../scenes/long-fiber.toml")),
    ("rotor", include_str!("../scenes/rotor.toml")),
    (
        "double-pendulum",
        include_str!("../scenes/double-pendulum.toml"),
    ),
    ("torus", include_str!("../scenes/torus.toml")),
    ("water", include_str!("../scenes/water.toml")),
    (
        "pendulum-expressions",
        include_str!("../scenes/pendulum-expressions.toml"),
    ),
    (
        "chain-expressions",
        include_str!("../scenes/chain-expressions.toml"),
    ),
];
