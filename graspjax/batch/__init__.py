"""The batch driver: many worlds of `procedure`, compiled once, played chunk by chunk.

`plan` (host: jobs -> worlds -> groups -> chunks), `program` (compiled programs on every local
device, chunks played on them; `exported` keeps traced programs across processes), `rows`
(records -> the one schema of attempt and round rows).
"""
