"""Trajectory files of `sdae-study simulate`, read back by readers that share no code with the
writers: extended XYZ by ASE, VTK by VTK's own XML reader (the .pvd collection by the standard
XML parser). Each file holds the simulated states of the same seed bit for bit: those of the
command's CSV output, and those `sdae.simulate` returns."""

import csv
import pathlib
import subprocess
import xml.etree.ElementTree as ElementTree

import ase.io
import numpy as np
import pytest
from vtkmodules.util.numpy_support import vtk_to_numpy
from vtkmodules.vtkCommonDataModel import VTK_POLY_LINE
from vtkmodules.vtkIOXML import vtkXMLUnstructuredGridReader

PATHS, EVERY, SEED = 3, 16, 5


def simulate(command_line, out, scene, steps, file_format):
    """Runs `simulate` and returns the folder of its files."""
    subprocess.run(
        [
            command_line, "simulate", "--scene", scene, "--paths", str(PATHS),
            "--steps", str(steps), "--every", str(EVERY * steps // 64), "--seed", str(SEED),
            "--format", file_format, "--out", str(out),
        ],
        check=True,
        capture_output=True,
    )
    return pathlib.Path(out) / "simulate" / scene


def csv_states(folder, scene):
    """The CSV output's positions by (path, step), with their times."""
    with open(folder / f"{scene}.csv") as f:
        rows = list(csv.reader(f))
    assert rows[0][:3] == ["path", "step", "time"]
    return {
        (int(row[0]), int(row[1])): (float(row[2]), np.array([float(x) for x in row[3:]]))
        for row in rows[1:]
    }


@pytest.mark.parametrize("scene, dim", [("pendulum", 2), ("chain-molecule", 3)])
def test_ase_reads_the_xyz_files_and_finds_the_simulated_positions(tmp_path, command_line, scene, dim):
    xyz = simulate(command_line, tmp_path / "xyz", scene, 64, "xyz")
    expected = csv_states(simulate(command_line, tmp_path / "csv", scene, 64, "csv"), scene)
    for path in range(PATHS):
        frames = ase.io.read(xyz / f"{scene}.path-{path}.xyz", index=":")
        assert len(frames) == 64 // EVERY + 1
        for j, atoms in enumerate(frames):
            assert atoms.info["path"] == path
            assert atoms.info["step"] == j * EVERY
            time, r = expected[(path, j * EVERY)]
            assert atoms.info["time"] == time
            assert not atoms.pbc.any()
            positions = atoms.get_positions()
            # Every digit, and a planar system's particles at z = 0.
            np.testing.assert_array_equal(positions[:, :dim].ravel(), r)
            np.testing.assert_array_equal(positions[:, dim:], 0.0)
            assert atoms.arrays["vel"].shape == positions.shape


def read_grid(file):
    reader = vtkXMLUnstructuredGridReader()
    reader.SetFileName(str(file))
    reader.Update()
    return reader.GetOutput()


def test_vtk_reads_the_series_and_finds_the_fibers_positions(tmp_path, command_line):
    # h = 1/512 on the fiber: no path stops early.
    vtk = simulate(command_line, tmp_path / "vtk", "fiber", 512, "vtk")
    expected = csv_states(simulate(command_line, tmp_path / "csv", "fiber", 512, "csv"), "fiber")
    by_time = {(time, path): r for (path, _), (time, r) in expected.items()}
    datasets = ElementTree.parse(vtk / "fiber.pvd").getroot().findall("./Collection/DataSet")
    assert len(datasets) == 512 // (EVERY * 8) + 1
    for dataset in datasets:
        time = float(dataset.get("timestep"))
        grid = read_grid(vtk / dataset.get("file"))
        assert grid.GetNumberOfCells() == PATHS
        points = vtk_to_numpy(grid.GetPoints().GetData())
        paths = vtk_to_numpy(grid.GetCellData().GetArray("path"))
        np.testing.assert_array_equal(paths, range(PATHS))
        assert vtk_to_numpy(grid.GetFieldData().GetArray("TimeValue"))[0] == time
        for cell in range(PATHS):
            assert grid.GetCellType(cell) == VTK_POLY_LINE
            ids = grid.GetCell(cell).GetPointIds()
            beads = points[[ids.GetId(i) for i in range(ids.GetNumberOfIds())]]
            np.testing.assert_array_equal(beads.ravel(), by_time[(time, paths[cell])])


def test_the_files_hold_the_paths_of_the_python_package(tmp_path, command_line):
    sdae = pytest.importorskip("sdae")
    scene = "chain-molecule"
    xyz = simulate(command_line, tmp_path, scene, 64, "xyz")
    paths = sdae.simulate(scene, "half-explicit-practical", paths=PATHS, steps=64, seed=SEED, every=EVERY)
    for path in range(PATHS):
        frames = ase.io.read(xyz / f"{scene}.path-{path}.xyz", index=":")
        assert [a.info["time"] for a in frames] == list(paths.times)
        for j, atoms in enumerate(frames):
            np.testing.assert_array_equal(atoms.get_positions().ravel(), paths.positions[path, j])
            np.testing.assert_array_equal(atoms.arrays["vel"].ravel(), paths.velocities[path, j])
