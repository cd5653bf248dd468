"""Private helpers of skf_ref, used by every layer and by no user directly.

Input checks and their errors (:mod:`.checks`; the errors are public as
``skf_ref.InputError`` and ``skf_ref.InputTypeError``), files written whole or not at all
(:mod:`.atomic_files`), memory budgets (:mod:`.memory`), what produced a result
(:mod:`.provenance`), the ``"skf_ref"`` log and ``verbose=`` (:mod:`.log`), optional
packages and the extras that install them (:mod:`.extras`), and the old module paths of
0.2 (:mod:`.moved`). Nothing here imports another layer of the package.
"""
