"""Catalogue of the staged real datasets: registry name → files under the data root and reader.

Each entry names its files relative to a data root (:mod:`slamarena.datasets.dataroot`), the role of
each, the reader (``"module:function"``, imported on first use) and its preset options
(``arguments``). A reader declares its options as a ``Params`` model (``@with_params``);
:meth:`CatalogueEntry.load` validates the preset with the caller's keywords applied through that
model (an unknown or bad option is an error naming it) and calls ``reader(paths, name, params=…)``
with the entry's :class:`Files`: role → path, each file found when the reader asks for it. A role in
``optional`` is read only under some options (Victoria Park's iSAM copy, read with
``variant="isam"``): the dataset is present without it, and asking for it when it is absent raises
:class:`DatasetNotFoundError` as for any file.
"""
from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from pathlib import Path

from slamarena.params import params_model
from slamarena.targets import import_target

from .dataroot import find, locate

__all__ = ["CatalogueEntry", "Files", "CATALOGUE"]


class Files(Mapping):
    """Role → path of a dataset's files, each found on access (:func:`~slamarena.datasets.dataroot.find`).

    Iterating gives the required roles and the optional roles whose file is present.
    """

    def __init__(self, dataset: str, relative: dict[str, str], optional: tuple[str, ...]):
        self.dataset, self.relative, self.optional = dataset, relative, optional

    def __getitem__(self, role: str) -> Path:
        return find(self.relative[role], self.dataset)

    def __iter__(self) -> Iterator[str]:
        return (role for role, rel in self.relative.items() if role not in self.optional or locate(rel) is not None)

    def __len__(self) -> int:
        return sum(1 for _ in self)


@dataclass(frozen=True)
class CatalogueEntry:
    name: str
    kind: str
    ground_truth: str
    files: tuple[str, ...]
    reader: str
    roles: tuple[str, ...] = ()
    arguments: dict = field(default_factory=dict)
    citation: str = ""
    optional: tuple[str, ...] = ()

    @property
    def relative(self) -> dict[str, str]:
        """Role → path relative to a data root."""
        return dict(zip(self.roles or (f"file{k}" for k in range(len(self.files))), self.files))

    def paths(self) -> Files:
        return Files(self.name, self.relative, self.optional)

    def present(self) -> bool:
        """Every file the dataset needs (its optional ones aside) is under a data root or in the GTSAM wheel."""
        return all(locate(rel) is not None for role, rel in self.relative.items() if role not in self.optional)

    def load(self, **params):
        """The dataset read with the preset ``arguments``, ``params`` applied over them (validated before any file is found)."""
        reader = import_target(self.reader)
        options = params_model(reader).of(self.arguments, params)
        return reader(self.paths(), self.name, params=options)


# ---------------------------------------------------------------------------- citations
_MRCLAM = ("K.Y.K. Leung, Y. Halpern, T.D. Barfoot, H.H.T. Liu, \"The UTIAS Multi-Robot Cooperative Localization "
           "and Mapping Dataset\", IJRR 30(8):969-974, 2011")
_VICTORIA = ("J. Guivant, E. Nebot, \"Optimization of the simultaneous localization and map-building algorithm for "
             "real-time implementation\", IEEE T-RA 17(3), 2001; pre-processing: M. Kaess, A. Ranganathan, F. Dellaert, "
             "\"iSAM: Incremental Smoothing and Mapping\", IEEE TRO 24(6), 2008")
_ISAM = "M. Kaess, A. Ranganathan, F. Dellaert, \"iSAM: Incremental Smoothing and Mapping\", IEEE TRO 24(6), 2008"
_OLSON = "E. Olson, J. Leonard, S. Teller, \"Fast iterative alignment of pose graphs with poor initial estimates\", ICRA 2006"
_SESYNC = ("D.M. Rosen, L. Carlone, A.S. Bandeira, J.J. Leonard, \"SE-Sync: a certifiably correct algorithm for "
           "synchronization over the special Euclidean group\", IJRR 38(2-3), 2019")
_CARLONE2D = "L. Carlone, A. Censi, \"From angular manifolds to the integer lattice\", IEEE TRO 30(2), 2014"
_CARLONE3D = "L. Carlone, R. Tron, K. Daniilidis, F. Dellaert, \"Initialization techniques for 3D SLAM\", ICRA 2015"
_GTSAM = "F. Dellaert and contributors, GTSAM (Georgia Tech), examples/Data"
_LAGO = "L. Carlone et al., \"A fast and accurate approximation for planar pose graph optimization\", IJRR 2014"
_RADISH = "A. Howard, N. Roy, \"The Robotics Data Set Repository (Radish)\", 2003"
_PLAZA = ("J. Djugash, S. Singh, G. Kantor, W. Zhang, \"Range-only SLAM for robots operating cooperatively with sensor "
          "networks\", ICRA 2006; GTSAM copies: B. Boots, G. Gordon, \"A spectral learning approach to range-only SLAM\", ICML 2013")
_KUEMMERLE = ("R. Kuemmerle et al., \"On measuring the accuracy of SLAM algorithms\", Autonomous Robots 27(4):387-407, 2009")


def _mrclam() -> dict[str, CatalogueEntry]:
    out = {}
    for dataset in (1, 6):
        d = f"utias_mrclam/MRCLAM_Dataset{dataset}"
        for robot in range(1, 6):
            roles = ["odometry", "measurement", "barcodes", "landmarks"]
            files = [f"{d}/Robot{robot}_Odometry.dat.gz", f"{d}/Robot{robot}_Measurement.dat.gz", f"{d}/Barcodes.dat",
                     f"{d}/Landmark_Groundtruth.dat"]
            if dataset == 6:
                roles.append("groundtruth")
                files.append(f"{d}/Robot{robot}_Groundtruth.dat.gz")
            name = f"utias:{dataset}/robot{robot}"
            out[name] = CatalogueEntry(
                name=name, kind="landmarks (range-bearing, velocity odometry, real indoor)",
                ground_truth="Vicon poses + surveyed landmarks" if dataset == 6 else "surveyed landmarks only",
                files=tuple(files), roles=tuple(roles), reader="slamarena.datasets.formats.mrclam:read", citation=_MRCLAM)
    return out


def _plaza() -> dict[str, CatalogueEntry]:
    out = {}
    for run in ("Plaza1", "Plaza2"):
        d = f"plaza_range_only/{run}"
        out[f"plaza:{run}"] = CatalogueEntry(
            name=f"plaza:{run}", kind="range-only (beacon ranges + odometry increments, real outdoor)",
            ground_truth="GPS-based poses + surveyed beacons", files=(f"{d}_DR.txt", f"{d}_TD.txt", f"{d}_.mat"),
            roles=("odometry", "ranges", "truth"), reader="slamarena.datasets.formats.plaza:read", citation=_PLAZA)
    return out


_G2O = {
    # name: (file, kind, ground truth, ground-truth file, citation)
    "intel": ("sesync_g2o/intel.g2o", "pose graph 2D, real (Intel lab)", "none", None, f"{_SESYNC}; {_CARLONE2D}"),
    "MIT": ("sesync_g2o/MIT.g2o", "pose graph 2D, real (Killian Court)", "none", None, f"{_SESYNC}; {_CARLONE2D}"),
    "CSAIL": ("sesync_g2o/CSAIL.g2o", "pose graph 2D, real (no initial guess)", "none", None, f"{_SESYNC}; {_CARLONE2D}"),
    "ais2klinik": ("sesync_g2o/ais2klinik.g2o.gz", "pose graph 2D, real (Freiburg)", "none", None, f"{_SESYNC}; {_CARLONE2D}"),
    "manhattan": ("sesync_g2o/manhattan.g2o", "pose graph 2D, simulated (M3500, no initial guess)",
                  "true poses (iSAM noise-free file)", "isam_data/groundtruth/manhattanOlson3500_groundtruth.txt",
                  f"{_OLSON}; {_SESYNC}"),
    "city10000": ("sesync_g2o/city10000.g2o.gz", "pose graph 2D, simulated", "true poses (iSAM noise-free file)",
                  "isam_data/groundtruth/city10000_groundtruth.txt", f"{_ISAM}; {_SESYNC}"),
    "parking-garage": ("sesync_g2o/parking-garage.g2o.gz", "pose graph 3D, real", "none", None, f"{_SESYNC}; {_CARLONE3D}"),
    "sphere2500": ("sesync_g2o/sphere2500.g2o.gz", "pose graph 3D, simulated", "none", None, f"{_SESYNC}; {_CARLONE3D}"),
    "smallGrid3D": ("sesync_g2o/smallGrid3D.g2o", "pose graph 3D, simulated", "none", None, _SESYNC),
    "tinyGrid3D": ("sesync_g2o/tinyGrid3D.g2o", "pose graph 3D, simulated", "none", None, _SESYNC),
    "noisyToyGraph": ("gtsam_examples_data/noisyToyGraph.txt", "pose graph 2D, toy",
                      "reference answer (GTSAM's, within 1e-2 of the optimum): g2o:optimizedNoisyToyGraph", None, f"{_GTSAM}; {_LAGO}"),
    "optimizedNoisyToyGraph": ("gtsam_examples_data/optimizedNoisyToyGraph.txt", "pose graph 2D, toy (GTSAM's reference answer)",
                               "is GTSAM's reference answer (LAGO-based, 2.4e-3 from the optimum)", None, f"{_GTSAM}; {_LAGO}"),
    "orientationsNoisyToyGraph": ("gtsam_examples_data/orientationsNoisyToyGraph.txt", "pose graph 2D, toy (LAGO)",
                                  "is the expected LAGO answer", None, f"{_GTSAM}; {_LAGO}"),
    "pose2example": ("gtsam_examples_data/pose2example.txt", "pose graph 2D, toy", "none", None, _GTSAM),
    "toyExample": ("gtsam_examples_data/toyExample.g2o", "pose graph 3D, toy", "none", None, _GTSAM),
    "Klaus3": ("gtsam_examples_data/Klaus3.g2o", "pose graph 3D, toy", "none", None, _GTSAM),
    "pose3example": ("gtsam_examples_data/pose3example.txt", "pose graph 3D, toy", "none", None, _GTSAM),
    "pose3example-grid": ("gtsam_examples_data/pose3example-grid.txt", "pose graph 3D, toy", "none", None, _GTSAM),
    "simpleGraph10gradIter": ("gtsam_examples_data/simpleGraph10gradIter.txt", "pose graph 3D, toy", "none", None, _GTSAM),
}
_TORO = {
    "w100": ("gtsam_examples_data/w100.graph", "pose graph 2D (TORO), simulated Manhattan world", "none"),
    "example": ("gtsam_examples_data/example.graph", "pose graph 2D (TORO) + bearing-range landmarks", "none"),
}
_ISAM_FILES = {
    "manhattanOlson3500": ("isam_data/manhattanOlson3500.txt", "isam_data/groundtruth/manhattanOlson3500_groundtruth.txt",
                           "pose graph 2D, simulated (M3500)", f"{_OLSON}; {_ISAM}"),
    "city10000": ("isam_data/city10000.txt.gz", "isam_data/groundtruth/city10000_groundtruth.txt",
                  "pose graph 2D, simulated", _ISAM),
    "cityTrees10000": ("isam_data/cityTrees10000.txt", "isam_data/groundtruth/cityTrees10000_groundtruth.txt",
                       "pose + landmark graph 2D, simulated (100 trees)", _ISAM),
    "w20000": ("gtsam_examples_data/w20000.txt.gz", None, "pose graph 2D, simulated Manhattan world", _GTSAM),
}
#: CARMEN logs: name → (file, no-return threshold max_range [m], note). 80 m: the SICK LMS codes 81.8-81.91 m
#: (no real return above 62 m in any log); 50 m: logs whose readings pile up at 50-51.3 m; 32.767 m: int16 mm code.
_CARMEN_RAW = {
    "intel": ("radish_laser_logs/intel.clf.bz2", 80.0, "Intel Research Lab Seattle (D. Haehnel)"),
    "fr079": ("radish_laser_logs/fr079.clf.bz2", 80.0, "Freiburg building 079 (C. Stachniss)"),
    "aces": ("radish_laser_logs/aces.clf.bz2", 50.0, "ACES building, UT Austin (P. Beeson)"),
    "mit-csail": ("radish_laser_logs/mit-csail.clf.bz2", 80.0, "MIT CSAIL building (C. Stachniss)"),
    "fr-clinic": ("radish_laser_logs/fr-clinic_robotlaser.clf.bz2", 80.0, "Freiburg University Hospital (AIS)"),
}
#: the Kümmerle et al. relations files staged beside the raw logs (radish_laser_logs/relations/SOURCE.md)
_CARMEN_RELATIONS = {name: f"radish_laser_logs/relations/{name}.relations" for name in ("intel", "fr079", "mit-csail", "fr-clinic")}
_CARMEN_CORRECTED = {
    "acapulco": 50.0, "aces": 50.0, "belgioioso": 80.0, "csail": 80.0, "edmonton": 50.0, "fhw": 50.0,
    "freiburg-079": 80.0, "freiburg-101": 80.0, "freiburg-campus": 80.0, "infinite-corridor": 50.0, "intel": 80.0,
    "orebro": 32.767, "seattle": 80.0,
}


def _graphs() -> dict[str, CatalogueEntry]:
    out = {}
    for name, (rel, kind, truth, gt, cite) in _G2O.items():
        files, roles = ((rel, gt), ("graph", "ground_truth")) if gt else ((rel,), ("graph",))
        out[f"g2o:{name}"] = CatalogueEntry(f"g2o:{name}", kind, truth, files, "slamarena.datasets.formats.g2o:load", roles, citation=cite)
    for name, (rel, kind, truth) in _TORO.items():
        out[f"g2o:{name}"] = CatalogueEntry(f"g2o:{name}", kind, truth, (rel,), "slamarena.datasets.formats.toro:load", ("graph",), citation=_GTSAM)
    for name, (rel, gt, kind, cite) in _ISAM_FILES.items():
        files, roles = ((rel, gt), ("graph", "ground_truth")) if gt else ((rel,), ("graph",))
        truth = "true poses" + (" and landmarks" if "Trees" in name else "") + " (noise-free file)" if gt else "none"
        out[f"isam:{name}"] = CatalogueEntry(f"isam:{name}", kind, truth, files, "slamarena.datasets.formats.isam:load", roles, citation=cite)
    return out


def _carmen() -> dict[str, CatalogueEntry]:
    out = {}
    for name, (rel, max_range, owner) in _CARMEN_RAW.items():
        relations = _CARMEN_RELATIONS.get(name)
        out[f"carmen:{name}"] = CatalogueEntry(
            f"carmen:{name}", "laser log 2D (scans + odometry), real",
            "relations (Kümmerle et al. 2009), where staged" if relations else "none", (rel, relations) if relations else (rel,),
            "slamarena.datasets.formats.carmen:load", ("log", "relations") if relations else ("log",), {"max_range": max_range},
            f"{owner}; {_RADISH}; {_KUEMMERLE}", optional=("relations",) if relations else ())
    for name, max_range in _CARMEN_CORRECTED.items():
        rel = f"carmen_corrected_logs/{name}-corrected.log.gz"
        out[f"carmen-corrected:{name}"] = CatalogueEntry(
            f"carmen-corrected:{name}", "laser log 2D with SLAM-corrected poses", "SLAM reference poses (not independent)",
            (rel,), "slamarena.datasets.formats.carmen:load", ("log",), {"max_range": max_range, "corrected": True},
            f"{_RADISH}; data owners per log (via acschaefer/ple)")
    return out


CATALOGUE: dict[str, CatalogueEntry] = {
    **_mrclam(),
    "victoria_park": CatalogueEntry(
        name="victoria_park", kind="landmarks (odometry increments + tree observations, real outdoor)",
        ground_truth="none", files=("victoria_park/victoria_park_gtsam.txt", "victoria_park/victoriaPark_isam.txt"),
        roles=("gtsam", "isam"), reader="slamarena.datasets.formats.victoria_park:load", citation=_VICTORIA,
        optional=("isam",)),
    **_plaza(),
    **_graphs(),
    **_carmen(),
}
