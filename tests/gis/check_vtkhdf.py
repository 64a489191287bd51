#!/usr/bin/python3
"""Reads VTKHDF files with VTK's own reader (vtkHDFReader, Debian's python3-vtk9) and prints what
it sees as JSON, for tests/gis/vtkhdf_export_test.cpp to compare with results.h5: an independent
reader of the files fragsim writes. Exits non-zero, naming the file and VTK's message, when the
reader reports an error or reads no points. Usage: check_vtkhdf.py FILE..."""
import json
import sys

import vtk


def arrays(data):
    out = {}
    for i in range(data.GetNumberOfArrays()):
        a = data.GetArray(i)
        values = [a.GetValue(k) for k in range(a.GetNumberOfTuples())]
        out[a.GetName()] = {"count": len(values), "sum": sum(values), "first": values[:5]}
    return out


def describe(path):
    reader = vtk.vtkHDFReader()
    errors = []

    @vtk.calldata_type(vtk.VTK_STRING)
    def on_error(obj, event, message):
        errors.append(message)

    reader.AddObserver("ErrorEvent", on_error)
    reader.SetFileName(path)
    reader.Update()
    grid = reader.GetOutput()
    if errors or grid is None or grid.GetNumberOfPoints() == 0:
        sys.exit("check_vtkhdf.py: vtkHDFReader cannot read %s: %s" % (path, " ".join(errors)))
    types = sorted({grid.GetCellType(k) for k in range(grid.GetNumberOfCells())})
    first_cell = []
    if grid.GetNumberOfCells() > 0:
        ids = grid.GetCell(0).GetPointIds()
        first_cell = [ids.GetId(k) for k in range(ids.GetNumberOfIds())]
    return {
        "class": grid.GetClassName(),
        "points": grid.GetNumberOfPoints(),
        "cells": grid.GetNumberOfCells(),
        "bounds": list(grid.GetBounds()),
        "cell_types": types,
        "first_cell": first_cell,
        "cell_data": arrays(grid.GetCellData()),
        "point_data": arrays(grid.GetPointData()),
    }


if __name__ == "__main__":
    print(json.dumps({path: describe(path) for path in sys.argv[1:]}))
