"""`graspjax detect`'s image files: depth images from disk in, records out.

`inputs` (files, intrinsics, workspace, settings: checked before any work), `batches` (the
one-image kernel `perception.real_image.detect_real_image` batched over the files, views
returned with each result), `records` (one record per image: JSON, CSV row, printed line).
"""
