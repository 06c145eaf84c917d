"""check-config reads the delivery robot's orders database, read-only, and names its problem."""

from __future__ import annotations

import sqlite3
from pathlib import Path

import pytest

from behaviours.profiles.delivery.orders import create_database
from robotd.config import ConfigError
from robotd.config.loader import load_config


def config(tmp_path: Path, url: str, *, profile: str = "laundry") -> Path:
    path = tmp_path / "robotd.toml"
    path.write_text(f'[robot]\nname = "d"\nprofile = "{profile}"\nstate_dir = "{tmp_path}"\n\n'
                    f'[delivery]\ndatabase_url = "{url}"\n')
    return path


def problem(path: Path) -> str:
    with pytest.raises(ConfigError) as info:
        load_config(path)
    return str(info.value)


class TestDeliveryDatabase:
    def test_a_seeded_database_passes(self, tmp_path: Path) -> None:
        """A database with the seed's schema is a valid configuration."""
        create_database(tmp_path / "orders.db", [(1, "A", "B", 1, "k")], [(7, 1)])
        load_config(config(tmp_path, f"sqlite:///{tmp_path}/orders.db"))

    def test_a_missing_file_is_named_and_not_created(self, tmp_path: Path) -> None:
        """``robotd.toml:7: delivery.database_url: FILE: no such file``; nothing is created."""
        db = tmp_path / "missing.db"
        path = config(tmp_path, f"sqlite:///{db}")
        assert problem(path) == f"{path}:7: delivery.database_url: {db}: no such file"
        assert not db.exists()

    def test_a_missing_directory_is_named(self, tmp_path: Path) -> None:
        """A file in a directory that does not exist says which directory."""
        path = config(tmp_path, "sqlite:////nonexistent/dir/orders.db")
        assert problem(path).endswith(
            "/nonexistent/dir/orders.db: no such file (no directory /nonexistent/dir)")

    def test_a_text_file_is_not_a_database_and_is_left_alone(self, tmp_path: Path) -> None:
        """A text file named .db is 'not an SQLite database', and its bytes are unchanged."""
        db = tmp_path / "orders.db"
        db.write_text("id,name\n1,x\n")
        assert problem(config(tmp_path, f"sqlite:///{db}")).endswith(
            f"{db}: not an SQLite database")
        assert db.read_text() == "id,name\n1,x\n"

    def test_a_database_without_the_tables_is_named(self, tmp_path: Path) -> None:
        """An SQLite file without ``customers``/``orders`` names the missing tables."""
        db = tmp_path / "other.db"
        with sqlite3.connect(db) as conn:
            conn.execute("CREATE TABLE orders (id INTEGER)")
        conn.close()
        before = db.read_bytes()
        assert "no customers table" in problem(config(tmp_path, "sqlite:///other.db"))
        assert db.read_bytes() == before

    def test_the_delivery_profile_checks_the_default_url(self, tmp_path: Path) -> None:
        """With profile delivery and no [delivery] section, the default file is checked."""
        (tmp_path / "assets").mkdir()
        path = tmp_path / "robotd.toml"
        path.write_text(f'[robot]\nname = "d"\nprofile = "delivery"\nstate_dir = "{tmp_path}"\n')
        assert problem(path) == (f"{path}:3: delivery.database_url: {tmp_path}/assets/orders.db"
                                 " (the default sqlite:///assets/orders.db): no such file")

    def test_other_robots_read_no_database(self, tmp_path: Path) -> None:
        """A laundry config without a [delivery] database_url opens no database."""
        path = tmp_path / "robotd.toml"
        path.write_text('[robot]\nname = "x"\n')
        load_config(path)
