"""The model: what a checked scenario means, as every stage after the compiler reads it.

`program` (the `Program`, its participants and parameter layers), `activities` and `conditions`
(lowered steps, conditions and expectations), `tasks` (the task registry), `params` (the human
and robot parameters) and `units`. It depends on nothing of hubero's but the world's shapes and
the diagnostics' spans.
"""
