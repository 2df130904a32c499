"""`graspjax detect`: the paper's method on real depth images from disk.

`inputs` (files, intrinsics, workspace, settings: checked before any work), `detect` (batched
`perception.real_image.detect_real_image` over the files, views returned with each result),
`records` (one record per image: JSON, CSV row, printed line).
"""
