import sys

import pytest

from common.user_modules import UserModuleError, import_user_module


def test_a_module_beside_the_working_directory_imports_as_with_python_m(tmp_path, monkeypatch):
    (tmp_path / "users_own_mod.py").write_text("VALUE = 7\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(tmp_path))])
    assert import_user_module("users_own_mod").VALUE == 7
    assert sys.path[0] == str(tmp_path)


def test_whatever_the_module_raises_is_named(tmp_path, monkeypatch):
    (tmp_path / "users_broken_mod.py").write_text("raise KeyError('at import')\n")
    monkeypatch.chdir(tmp_path)
    monkeypatch.setattr(sys, "path", list(sys.path))
    with pytest.raises(UserModuleError, match=r"'users_broken_mod' does not import \(KeyError"):
        import_user_module("users_broken_mod")
    with pytest.raises(UserModuleError, match="ModuleNotFoundError"):
        import_user_module("no_such_users_mod")
