"""A file without data (empty, or only comments and blank lines) is a DataFormatError naming it, for every reader."""

from __future__ import annotations

import pytest

from slamarena.datasets import DataFormatError
from slamarena.datasets.formats import carmen, g2o, isam, mrclam, plaza, relations, toro, tum, victoria_park

#: a file with nothing in it but comments and blank lines, in each text format's comment syntax
COMMENTS = "# written by hand\n\n   \n\t\n# nothing else\n"


#: valid files of the multi-file readers, one per role
MRCLAM = {
    "odometry": "# t v w\n1.0 0.1 0.0\n2.0 0.1 0.0\n",
    "measurement": "# t code r b\n1.5 63 2.0 0.1\n",
    "barcodes": "# subject code\n6 63\n",
    "landmarks": "# subject x y sx sy\n6 1.0 2.0 0.01 0.01\n",
    "groundtruth": "# t x y th\n1.0 0 0 0\n2.0 0.1 0 0\n",
}
PLAZA = {"odometry": "1.0\t0.1\t0.0\n2.0\t0.1\t0.0\n", "ranges": "1.5\t2\t0\t10.0\n"}


def _one_role(read, good: dict, role: str):
    """``read(**files)`` with the file under test in ``role`` and the ``good`` files in the others."""

    def run(path):
        files = {name: path if name == role else path.with_name(f"{name}.txt") for name in good}
        for name, text in good.items():
            if name != role:
                files[name].write_text(text)
        return read(**files)

    return run


READERS = {
    **{f"mrclam {role}": _one_role(mrclam.read_robot, MRCLAM, role) for role in MRCLAM},
    **{
        f"plaza {role}": _one_role(lambda odometry, ranges: plaza.read_run(odometry, ranges), PLAZA, role)
        for role in PLAZA
    },
    "plaza mat": lambda p: plaza.read_mat(p, ("GT",)),
    "victoria_park": victoria_park.read,
    "g2o": g2o.read,
    "toro": toro.read,
    "isam": isam.read,
    "carmen": carmen.read,
    "relations": relations.read,
    "tum": tum.read,
}
#: a file of comments only, for every format that has comments (not the binary Plaza .mat)
NO_DATA = {name: COMMENTS for name in READERS}
del NO_DATA["plaza mat"]


@pytest.mark.parametrize(
    "reader, text",
    [(name, "") for name in READERS] + list(NO_DATA.items()),
    ids=[f"{name}-empty" for name in READERS] + [f"{name}-comments" for name in NO_DATA],
)
def test_a_file_without_data_is_an_error_naming_it(tmp_path, reader, text):
    path = tmp_path / "empty.txt"
    path.write_text(text)
    with pytest.raises(DataFormatError) as err:
        READERS[reader](path)
    assert err.value.path == str(path) and str(path) in str(err.value)
